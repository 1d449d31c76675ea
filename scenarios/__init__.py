"""Shipped scenario files, installed as the package ``mjsuff.scenarios`` (see pyproject.toml:
package-dir); ``mjsuff run NAME`` finds them by name, ``mjsuff scenarios`` lists them."""
