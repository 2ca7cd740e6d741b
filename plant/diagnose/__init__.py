"""Diagnosis: which effect the model misses, by model search on the fits, and its shared evidence vocabulary.
May import every floor below: ``plant.identify`` down to ``plant.host`` and the base modules."""
