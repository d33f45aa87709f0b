"""Identification in numpy/scipy: the equation-error fit, the damage states and indices,
the ensemble's uncertainty and the decisions that use it."""
