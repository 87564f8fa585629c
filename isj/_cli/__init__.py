"""The command line, one module per command group (see isj._cli.main)."""
