"""The one formatter home: Markdown tables, CSV and plots of every command and benchmark."""
