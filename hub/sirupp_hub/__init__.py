"""The notebooks hub of a SIRUPP class: authenticator, spawner, sandbox (hub/README.md)."""
