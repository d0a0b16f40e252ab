"""The commands' argparse and printing: one module per ``companion`` command."""
