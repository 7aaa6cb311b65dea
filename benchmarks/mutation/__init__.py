"""Mutation testing: a catalogue of small semantic bugs (catalogue.toml), each applied to a copy of the tree and
run against the tests that can reach it (run.py; impact.py selects the tests, plugin.py classifies the kills)."""
