"""Interchange formats, one module (or package) per format owning both directions: pose tables
(CSV), analysis results (JSON), BVH, glTF, and the exporters table."""
