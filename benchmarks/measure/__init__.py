"""Result generators: each measures one result of the registry (benchmarks/publish/registry.py) and
writes its JSON (and images); `python -m benchmarks.publish` renders the rest."""
