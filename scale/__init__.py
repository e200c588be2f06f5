"""Campaigns and tuning at scale: many closed-loop runs on Ray (``campaign``, ``tune``)."""
