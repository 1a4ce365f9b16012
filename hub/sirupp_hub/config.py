"""JupyterHub's configuration for a class, from DATA/hub/hub.json (written by `sirupp class
notebooks`, tools/class_commands.cpp). DATA/hub/jupyterhub_config.py only calls configure().
"""

import os

from .spawner import load_settings


def configure(c, settings_file):
    s = load_settings(settings_file)
    hub = os.path.dirname(settings_file)
    c.JupyterHub.ip = "127.0.0.1"
    c.JupyterHub.port = int(s["hub_port"])
    c.JupyterHub.hub_ip = s["hub_api_host"]
    c.JupyterHub.hub_port = int(s["hub_api_port"])
    c.ConfigurableHTTPProxy.api_url = f"http://127.0.0.1:{int(s['proxy_api_port'])}"
    c.ConfigurableHTTPProxy.command = ["/usr/bin/configurable-http-proxy"]
    c.ConfigurableHTTPProxy.pid_file = os.path.join(hub, "proxy.pid")
    c.JupyterHub.db_url = "sqlite:///" + os.path.join(hub, "jupyterhub.sqlite")
    c.JupyterHub.cookie_secret_file = os.path.join(hub, "cookie_secret")
    c.JupyterHub.pid_file = os.path.join(hub, "jupyterhub.pid")
    # A restarted hub finds the servers running (the spawner's state in the database).
    c.JupyterHub.cleanup_servers = False
    c.JupyterHub.cleanup_proxy = True
    c.JupyterHub.allow_named_servers = False
    c.JupyterHub.authenticator_class = "sirupp_hub.auth.SiruppAuthenticator"
    c.SiruppAuthenticator.class_url = s["class_url"]
    c.SiruppAuthenticator.secret_file = s["hub_secret_file"]
    c.SiruppAuthenticator.user_header = s.get("user_header", "")
    c.JupyterHub.spawner_class = "sirupp_hub.spawner.SiruppSpawner"
    c.SiruppSpawner.settings_file = settings_file
    c.Spawner.disable_user_config = True
    c.Spawner.default_url = "/tree/notebooks"
    c.Spawner.start_timeout = 60
    c.Spawner.http_timeout = 60
    poll = float(s.get("poll_interval_s", 30))
    c.Spawner.poll_interval = max(1, int(round(poll)))
    # The hub asks the proxy for activity this often; culling is the notebook server's own.
    c.JupyterHub.last_activity_interval = int(max(poll, min(300, float(s["idle_timeout_s"]) / 2)))
    c.JupyterHub.shutdown_on_logout = False
