"""The cell's scene and the tool's shape (docs/scene.md): the obstacles and solids
(``shapes``), the TCP's path through a sequence (``path``), the swept check (``collide``), the
grasp alternatives (``alternatives``) and ``check.SceneCheck``, what the plan uses. Only
``alternatives`` is imported without python-fcl."""
