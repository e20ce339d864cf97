"""The point files a CMM reads and writes (DMIS, XYZIJK, CSV) and the point set they carry. Imports
the rooms below it."""
