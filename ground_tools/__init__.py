"""What a user runs: `vtol` and its sub-commands (flights, figures)."""
