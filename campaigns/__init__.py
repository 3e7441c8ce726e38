"""The dissertation's experiments as campaign files (TOML data; imports nothing)."""
