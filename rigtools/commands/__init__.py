"""Sub-commands of ``rig``: one module per command, each with ``register(subparsers)``."""
