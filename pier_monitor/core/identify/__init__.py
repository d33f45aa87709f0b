"""Identification in numpy/scipy: the equation-error fit and the damage indices."""
