"""User workflows: the command line, tables, validation, discrepancy, sweeps."""
