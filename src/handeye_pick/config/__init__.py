"""The cell configuration: frozen typed sections read strictly from YAML.

``reader.py`` is the strict YAML reader (also used for detection files and pose lists),
``schema.py`` the dataclasses and their bounds, ``load.py`` ``load_config``, and one module per
section or group of sections parses them (``robot``, ``hand_eye``, ``motion`` and ``workspace``,
``poses`` with ``grasp``, ``place`` and ``capture``, ``payload``, ``gripper``).
"""
