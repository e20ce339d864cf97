"""Beyond one run on one face: the fewest points for a tolerance, a whole part's plan run in
parallel, and the probe path. Imports the rooms below it."""
