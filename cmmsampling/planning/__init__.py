"""Beyond one run on one face: the probe path. Imports the rooms below it."""
