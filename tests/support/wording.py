"""Patterns of the words the progress lines use for durations (cmmsampling.strategies.estimates)."""
AMOUNT = r"(\d+ (s|min)|\d+ h \d+ min)"
DURATION = rf"({AMOUNT}|under a second)"
LEFT = rf"(about {AMOUNT}|under a second) left"
