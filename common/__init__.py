"""The ground floor, shared by all tiers and importing none of them: message types,
conventions, the clock, the car's configuration, the TOML loader and the errors."""
