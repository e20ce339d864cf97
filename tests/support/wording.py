"""Patterns of the words the progress lines use for durations (cmmsampling.strategies.estimates)."""
DURATION = r"(\d+ (s|min)|\d+ h \d+ min|under a second)"
LEFT = rf"(about {DURATION}|under a second) left"
