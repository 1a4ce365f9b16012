"""The class server's internal API for the hub (class/hub_api.hpp), with the hub's secret."""

import json
import urllib.error
import urllib.request

SECRET_HEADER = "X-Sirupp-Hub-Secret"


class ClassApiError(Exception):
    """The class server refused (status, its message) or could not be reached (status 0)."""

    def __init__(self, status, message, starting=False):
        super().__init__(message)
        self.status = status
        self.message = message
        self.starting = starting  # the rig is on its way (a job not reported yet): ask again


class ClassApi:
    def __init__(self, class_url, secret_file, timeout=30):
        self.class_url = class_url.rstrip("/")
        self.secret_file = secret_file
        self.timeout = timeout

    def _secret(self):
        with open(self.secret_file, encoding="utf-8") as source:
            return source.readline().strip()

    def post(self, path, body=None):
        """POST /hub/api/PATH with a JSON body; the answer's JSON, or ClassApiError."""
        request = urllib.request.Request(
            f"{self.class_url}/hub/api/{path}", data=json.dumps(body or {}).encode(),
            method="POST",
            headers={SECRET_HEADER: self._secret(), "Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=self.timeout) as answer:
                return json.loads(answer.read().decode())
        except urllib.error.HTTPError as error:
            try:
                body = json.loads(error.read().decode())
            except ValueError:
                body = {}
            if not isinstance(body, dict):
                body = {}
            message = str(body.get("error", ""))
            raise ClassApiError(error.code, message or f"the class server answered {error.code}",
                                body.get("starting") is True)
        except (urllib.error.URLError, OSError) as error:
            raise ClassApiError(0, f"the class server at {self.class_url} cannot be reached: "
                                   f"{getattr(error, 'reason', error)}")

    def whoami(self, peer, headers, student="", token=""):
        return self.post("whoami", {"peer": peer, "headers": headers, "student": student,
                                    "token": token})["name"]

    def ensure_rig(self, student):
        return self.post(f"rigs/{student}/ensure")

    def touch_rig(self, student):
        return self.post(f"rigs/{student}/touch")
