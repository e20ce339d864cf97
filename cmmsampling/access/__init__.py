"""Where a contact probe can touch a part: the probe model, the part as obstacles, the axes
that reach each point. Imports only geometry (below it); strategies and planning use it."""
