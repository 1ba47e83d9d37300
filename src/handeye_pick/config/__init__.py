"""The cell configuration: frozen typed sections read strictly from YAML."""
