"""Private helpers shared by barkgen's packages (no algorithm, no front end)."""
