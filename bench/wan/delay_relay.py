#!/usr/bin/env python3
"""A TCP relay that adds a fixed one-way delay in each direction.

This kernel has no netem, so the WAN bench (run.sh) makes round-trip time
here: every chunk read from one side is written to the other side
DELAY_MS later, in order. Bandwidth is shaped elsewhere (tc tbf on the
veth pair); the relay sits on the client's side of that bottleneck, so
what it holds is at most rate x delay, the bytes a real path has in
flight.

usage: delay_relay.py LISTEN_HOST:PORT TARGET_HOST:PORT DELAY_MS
"""

import asyncio
import sys
import time


async def pump(reader, writer, delay):
    queue = asyncio.Queue()

    async def later():
        while True:
            due, data = await queue.get()
            if data is None:
                break
            wait = due - time.monotonic()
            if wait > 0:
                await asyncio.sleep(wait)
            writer.write(data)
            await writer.drain()
        writer.close()

    task = asyncio.create_task(later())
    try:
        while True:
            data = await reader.read(65536)
            if not data:
                break
            queue.put_nowait((time.monotonic() + delay, data))
    except ConnectionError:
        pass
    queue.put_nowait((0, None))
    try:
        await task
    except ConnectionError:
        pass


async def main():
    lhost, lport = sys.argv[1].rsplit(":", 1)
    thost, tport = sys.argv[2].rsplit(":", 1)
    delay = float(sys.argv[3]) / 1000.0

    async def serve(cr, cw):
        try:
            ur, uw = await asyncio.open_connection(thost, int(tport))
        except OSError:
            cw.close()
            return
        await asyncio.gather(pump(cr, uw, delay), pump(ur, cw, delay))

    server = await asyncio.start_server(serve, lhost, int(lport))
    async with server:
        await server.serve_forever()


if __name__ == "__main__":
    asyncio.run(main())
