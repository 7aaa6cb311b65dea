"""Document generators: docs/models.md and the README's images, from the code and the CLI."""
