"""BVH (Biovision hierarchy): reading any rig an artist brings, writing our animation."""
