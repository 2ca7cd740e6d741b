"""Identification: the frequency-domain, time-domain (inverse model) and rational fits, residuals, report text.
May import every floor below: ``plant.estimate`` down to ``plant.host`` and the base modules."""
