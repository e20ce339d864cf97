"""The inspection loop (the paper's Fig. 1 after the program): measured points read back, aligned
to the CAD model (align), judged against a profile tolerance (judge), and a virtual CMM that
writes what a CMM would measure on a misplaced part with a form error (simulate)."""
