"""The model: parameters, the thesis plants, the effects library (its base, the drive chain, the mechanics,
the drive's filters) and the friction response. May import: ``plant.errors``, ``plant.grid``, ``plant.arguments``."""
