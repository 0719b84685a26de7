"""CLI commands, one module each; every module has ``register(subparsers)``."""

#: command modules in the order ``mimika --help`` lists them
MODULES = (
    "catalogue", "characters", "pose", "knowledge", "speech", "timeline", "fit", "avatar",
    "learn", "gan", "studio", "serve", "news", "batch",
)
