"""The model: parameters, the thesis plants, the effects library (its base, the drive chain, the mechanics,
the drive's filters), the friction response, the plant's time-domain realisation and the planar machine (X, both Y
rails and the rotation stage from Lagrange's equations).
May import: ``plant.errors``, ``plant.grid``, ``plant.arguments``."""
