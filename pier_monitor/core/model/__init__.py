"""The pier and its physics: configuration, link model, Newmark solver, ground motions, units."""
