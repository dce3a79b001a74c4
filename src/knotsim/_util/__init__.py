"""Small helpers shared by every module that reads or writes files (TOML, JSON)."""
