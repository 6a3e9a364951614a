"""Figures: pictures of what the method sees and does."""
