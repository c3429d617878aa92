"""The render layer under the passes: frames and channels, the render graph, texture-unit bindings and the
drawing helpers every pass shares (docs/architecture.md)."""
