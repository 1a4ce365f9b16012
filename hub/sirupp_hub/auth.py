"""SiruppAuthenticator: sign-in to the hub as the class server does it, asked of the class server.

/hub/login (auto_login) forwards the browser's credentials to the class server's /hub/api/whoami:
the front's user header and the front's secret header as they came (with the address the hub's
proxy got them from), or ?student=NAME&token=TOKEN from the student's page's Notebooks link. The
class server answers with the student's name, or 403 naming who they are signed in as; the
roster, the tokens and the front's rules stay there (class/hub_api.hpp).
"""

import asyncio

from jupyterhub.auth import Authenticator
from jupyterhub.handlers import BaseHandler
from tornado import web
from traitlets import Unicode

from .classapi import ClassApi, ClassApiError

FRONT_SECRET_HEADER = "X-Sirupp-Front-Secret"


def request_peer(request):
    """The address that sent the request to the hub's proxy: the hub sees only its proxy (on
    127.0.0.1), which appends its own peer to X-Forwarded-For; tornado's remote_ip would believe
    a client's X-Real-Ip, so it is not used."""
    direct = getattr(request.connection.context, "_orig_remote_ip", None) or request.remote_ip
    forwarded = request.headers.get("X-Forwarded-For", "")
    if direct in ("127.0.0.1", "::1") and forwarded:
        return forwarded.split(",")[-1].strip()
    return direct


class SiruppLoginHandler(BaseHandler):
    def append_query_parameters(self, url, exclude=None):
        # The token stays out of the addresses the browser is sent on to (and their history).
        return super().append_query_parameters(
            url, exclude=list(exclude or []) + ["student", "token"])

    async def get(self):
        data = {"student": self.get_argument("student", ""),
                "token": self.get_argument("token", "")}
        user = await self.login_user(data)
        if user is None:
            raise web.HTTPError(403, "%s", getattr(self, "sirupp_refusal", "not signed in"))
        self.redirect(self.get_next_url(user))


class SiruppAuthenticator(Authenticator):
    class_url = Unicode(config=True, help="the class server, as the hub reaches it")
    secret_file = Unicode(config=True, help="DATA/hub.secret (class/hub_api.hpp)")
    user_header = Unicode("", config=True, help="the front's user header ('' = no front)")

    auto_login = True

    def get_handlers(self, app):
        return [("/login", SiruppLoginHandler)]

    async def authenticate(self, handler, data):
        headers = {}
        for name in (self.user_header, FRONT_SECRET_HEADER):
            if name and name in handler.request.headers:
                headers[name] = handler.request.headers[name]
        api = ClassApi(self.class_url, self.secret_file)
        try:
            return await asyncio.get_running_loop().run_in_executor(
                None, api.whoami, request_peer(handler.request), headers,
                (data or {}).get("student", ""), (data or {}).get("token", ""))
        except ClassApiError as error:
            handler.sirupp_refusal = error.message
            self.log.warning("sign-in refused: %s", error.message)
            return None
