"""PI synthesis: convex-concave scan and exact formulations, independent verification, gain
schedules, design from measured responses."""
