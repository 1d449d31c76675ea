"""MJCF models, installed as the package ``mjsuff.models`` (see pyproject.toml: package-dir)."""
