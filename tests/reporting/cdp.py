"""A minimal Chrome DevTools Protocol client over a pipe (``--remote-debugging-pipe``).

Enough for the browser test of the HTML report: open a page in headless Chromium, record
console messages, exceptions, log entries and network requests, take a full-page
screenshot and print to PDF. Chromium reads commands on fd 3 and writes replies and events
on fd 4, each message JSON terminated by a NUL byte. No third-party package.
"""

from __future__ import annotations

import base64
import fcntl
import json
import os
import select
import shutil
import subprocess
import tempfile
import time

#: Flags that keep Chromium off the network and quiet on a closed machine.
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-default-apps", "--disable-extensions", "--hide-scrollbars",
    "--remote-debugging-pipe",
)


def _high_fd(fd: int) -> int:
    """``fd`` duplicated to a number >= 10 (close-on-exec), the original closed."""
    new = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
    os.close(fd)
    return new


def chromium_path() -> str | None:
    """The Chromium executable (Debian's ``chromium``), or None."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        p = shutil.which(name)
        if p:
            return p
    return None


class Browser:
    """Headless Chromium driven through the DevTools pipe (a context manager)."""

    def __init__(self, executable: str, timeout_s: float = 60.0):
        self.timeout_s = timeout_s
        self._profile = tempfile.TemporaryDirectory(prefix="isodesign-chromium-")
        # the pipe ends move above fd 10 first, so that putting them on fd 3 and fd 4 in the
        # child never overwrites one with the other (nor keeps a close-on-exec flag)
        to_child_r, self._to_child_w = map(_high_fd, os.pipe())
        self._from_child_r, from_child_w = map(_high_fd, os.pipe())

        def _fds():  # in the child: the pipe ends on fd 3 (commands) and fd 4 (replies)
            os.dup2(to_child_r, 3)
            os.dup2(from_child_w, 4)

        self.proc = subprocess.Popen(
            [executable, *CHROMIUM_FLAGS, f"--user-data-dir={self._profile.name}",
             "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            preexec_fn=_fds, close_fds=False,
        )
        os.close(to_child_r)
        os.close(from_child_w)
        self._buf = b""
        self._id = 0
        self.events: list[dict] = []

    # -- protocol -------------------------------------------------------------------------
    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> int:
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._to_child_w, json.dumps(msg).encode() + b"\0")
        return self._id

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError("no reply from Chromium")
            ready, _, _ = select.select([self._from_child_r], [], [], left)
            if ready:
                chunk = os.read(self._from_child_r, 1 << 20)
                if not chunk:
                    raise RuntimeError("Chromium closed the DevTools pipe")
                self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        return json.loads(raw)

    def call(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        """Send a command and wait for its reply (events meanwhile are recorded)."""
        mid = self._send(method, params, session)
        deadline = time.monotonic() + self.timeout_s
        while True:
            msg = self._read_message(deadline)
            if msg.get("id") == mid:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg.get("result", {})
            if "method" in msg:
                self.events.append(msg)

    def wait_for(self, method: str, timeout_s: float | None = None) -> dict:
        """Wait for an event (returns it; earlier events stay recorded)."""
        for ev in self.events:
            if ev["method"] == method:
                return ev
        deadline = time.monotonic() + (timeout_s or self.timeout_s)
        while True:
            msg = self._read_message(deadline)
            if "method" in msg:
                self.events.append(msg)
                if msg["method"] == method:
                    return msg

    # -- a page ---------------------------------------------------------------------------
    def open(self, url: str, width: int = 1280, height: int = 900) -> str:
        """Open ``url`` in a new tab with logging and network recording; return the session."""
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget", {"targetId": target,
                                                      "flatten": True})["sessionId"]
        for domain in ("Runtime", "Log", "Network", "Page"):
            self.call(f"{domain}.enable", session=session)
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
                  session=session)
        self.call("Page.navigate", {"url": url}, session=session)
        self.wait_for("Page.loadEventFired")
        time.sleep(0.3)  # late console messages
        self.call("Runtime.evaluate", {"expression": "1"}, session=session)  # drain events
        return session

    def screenshot(self, session: str, path) -> bytes:
        """A full-page PNG screenshot written to ``path``."""
        data = self.call("Page.captureScreenshot",
                         {"format": "png", "captureBeyondViewport": True}, session=session)
        png = base64.b64decode(data["data"])
        with open(path, "wb") as fh:
            fh.write(png)
        return png

    def print_pdf(self, session: str) -> bytes:
        """The page printed to PDF (A4, the page's print style sheet)."""
        data = self.call("Page.printToPDF", {"preferCSSPageSize": True,
                                             "printBackground": True}, session=session)
        return base64.b64decode(data["data"])

    def problems(self, page_url: str) -> list[str]:
        """Console errors, exceptions, error log entries, failed or foreign requests."""
        out = []
        for ev in self.events:
            m, p = ev["method"], ev.get("params", {})
            if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert",
                                                                        "warning"):
                out.append(f"console {p['type']}: {p.get('args')}")
            elif m == "Runtime.exceptionThrown":
                out.append(f"exception: {p.get('exceptionDetails', {}).get('text')}")
            elif m == "Log.entryAdded" and p.get("entry", {}).get("level") in ("error",
                                                                                "warning"):
                out.append(f"log {p['entry']['level']}: {p['entry'].get('text')} "
                           f"{p['entry'].get('url', '')}")
            elif m == "Network.requestWillBeSent":
                url = p.get("request", {}).get("url", "")
                if url != page_url:
                    out.append(f"request: {url[:120]}")
            elif m == "Network.loadingFailed":
                out.append(f"failed resource: {p.get('errorText')}")
        return out

    def close(self) -> None:
        """Close the browser and its pipes."""
        try:
            self._send("Browser.close")
            self.proc.wait(timeout=10)
        except Exception:
            self.proc.kill()
            self.proc.wait(timeout=10)
        for fd in (self._to_child_w, self._from_child_r):
            try:
                os.close(fd)
            except OSError:
                pass
        self._profile.cleanup()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
