"""Report commands: each prints JSON (and may write plots under docs/img/) for the numbers quoted in docs/."""
