"""Rendering techniques, one module per technique."""
from .base import Technique
from .registry import get_technique, technique_names

__all__ = ["Technique", "get_technique", "technique_names"]
