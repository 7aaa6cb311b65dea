"""One module per command: its own checks of options and outputs, and its `cmd_*` function."""
