"""The PDF report: configuration, cached pipeline steps, figures and pages (``isj report``)."""
