"""Broken variants of the FMI standard's Reference FMUs, built at test time from the C
sources each FMU ships (issue 24, item 8: a stranger's code with a planted defect)."""
