"""The paper's experiments as data: its velocity set-point profiles (profiles.py) and the five scenarios that fly
them, with their failures and the paper's results to compare (experiments.py). Used by `vtol scenario`,
`vtol fly` and the autopilot's `--profile`."""
