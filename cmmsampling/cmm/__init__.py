"""A live CMM: probe points measured over I++ DME (the open TCP protocol most CMM controllers
speak), :mod:`.protocol` (commands and answers), :mod:`.client` (measure a plan) and
:mod:`.server` (a simulated I++ DME server: the virtual CMM behind the protocol). Imports the
rooms below it."""
