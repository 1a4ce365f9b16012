"""Byte forwarders between TCP and Unix-domain sockets (asyncio), for the notebook sandbox.

Outside the sandbox the hub's proxy reaches the student's notebook server on 127.0.0.1:PORT, which
is forwarded to the server's Unix socket; inside, the notebook server reaches the hub's API on its
own 127.0.0.1:PORT (the sandbox's `lo`), forwarded to a Unix socket the outside forwards on to the
hub. No TCP path crosses the sandbox's network namespace.

Run alone: python3 -m sirupp_hub.forward tcp:127.0.0.1:8081 unix:/run/sirupp/hubapi.sock
"""

import asyncio
import os
import signal
import sys


def parse_address(text):
    """('tcp', host, port) or ('unix', path); ValueError naming the text otherwise."""
    if text.startswith("unix:") and len(text) > 5:
        return ("unix", text[5:])
    if text.startswith("tcp:"):
        host, _, port = text[4:].rpartition(":")
        if host and port.isdigit() and 0 < int(port) < 65536:
            return ("tcp", host, int(port))
    raise ValueError(f"address '{text}': expected tcp:HOST:PORT or unix:PATH")


async def _pipe(reader, writer):
    try:
        while True:
            data = await reader.read(65536)
            if not data:
                break
            writer.write(data)
            await writer.drain()
    except (ConnectionError, OSError):
        pass
    finally:
        try:
            writer.close()
        except OSError:
            pass


async def _open(address):
    if address[0] == "unix":
        return await asyncio.open_unix_connection(address[1])
    return await asyncio.open_connection(address[1], address[2])


async def serve(listen, target):
    """Starts a server on `listen` that forwards every connection to `target`; returns it."""

    async def handle(reader, writer):
        try:
            target_reader, target_writer = await _open(target)
        except OSError:
            writer.close()
            return
        await asyncio.gather(_pipe(reader, target_writer), _pipe(target_reader, writer))

    if listen[0] == "unix":
        try:
            os.unlink(listen[1])
        except FileNotFoundError:
            pass
        server = await asyncio.start_unix_server(handle, listen[1])
        os.chmod(listen[1], 0o600)
        return server
    return await asyncio.start_server(handle, listen[1], listen[2], reuse_address=True)


def main(argv):
    if len(argv) != 2:
        print("usage: python3 -m sirupp_hub.forward LISTEN TARGET (tcp:HOST:PORT or unix:PATH)",
              file=sys.stderr)
        return 2
    try:
        listen, target = parse_address(argv[0]), parse_address(argv[1])
    except ValueError as error:
        print(f"sirupp_hub.forward: {error}", file=sys.stderr)
        return 2

    async def run():
        server = await serve(listen, target)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)
        await stop.wait()
        server.close()

    asyncio.run(run())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
