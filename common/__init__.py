"""Shared across tiers: message types, conventions, the clock, configuration and errors."""
