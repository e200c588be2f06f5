"""Tier 1: the Main orchestrator that owns every manager and moves all data between them."""
