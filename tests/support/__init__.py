"""Helpers the tests share: faces of every kind (faces), the sweep over real CAD files (sweep),
a DMIS syntax check (dmis_syntax), and a toy strategy and a toy file format added the way a
user adds one (toy_strategy, toy_format)."""
