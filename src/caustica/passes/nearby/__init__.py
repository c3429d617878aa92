"""Passes for the geometry near a refractor or mirror: impostors (Hu and Qin 2.2) and Wyman's nearby planes and
searches."""
