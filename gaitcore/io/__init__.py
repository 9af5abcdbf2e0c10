"""File formats: pose tables (CSV), analysis results (JSON), and later BVH and glTF."""
