"""Pure-numpy algorithm core. Nothing in this package may import pydrake."""
