"""``isj app``: the design space in the browser (docs/app.md).

:mod:`isj.app.state` turns the page's design into every number and curve it shows (pure
Python, tested without a browser); :mod:`isj.app.jobs` runs the slow work (an FE solve, the
surrogate's build) in a child process that can be stopped; :mod:`isj.app.server` is the Bokeh
page and server.
"""
