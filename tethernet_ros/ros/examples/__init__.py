"""Examples of nodes a user writes against the suite's contracts (docs/ros.md)."""
