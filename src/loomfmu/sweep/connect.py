"""Connecting to a dask scheduler given by its address, with a bounded wait.

dask's own ``Client(address, timeout=...)`` bounds only the TCP connect: a
peer that accepts the connection but is not a dask scheduler (an HTTP
server such as the dashboard port, anything answering with other bytes)
leaves it waiting for the handshake for ever, or reading a frame length out
of garbage (a 3 EiB allocation). :func:`check_scheduler` first asks the
address who it is (dask's ``identity`` message) in a fresh event loop, the
whole exchange bounded by ``timeout``; every failure becomes one ValueError
naming the address, what went wrong and what is allowed.
"""
from __future__ import annotations

import asyncio
import concurrent.futures

#: longest connect timeout, s
MAX_CONNECT_TIMEOUT = 600.0
ALLOWED = ("allowed: the address of a running dask scheduler (tcp://host:8786, "
           "not its dashboard) reachable within the connect timeout, or none for a "
           "local cluster")


def refused(address: str, why: str) -> ValueError:
    return ValueError(f"scheduler = {address!r:.80}: {why}; {ALLOWED}")


class _NotDask(Exception):
    """The peer accepted the connection and answered with other bytes."""


async def _identity(address: str, timeout: float):
    from distributed.comm import connect
    from distributed.comm.core import CommClosedError
    try:
        comm = await connect(address, timeout=timeout)
    except (MemoryError, ValueError) as exc:  # the handshake read garbage
        if "unknown address scheme" in str(exc):
            raise
        raise _NotDask(f"{type(exc).__name__}: {str(exc)[:120]}") from None
    try:
        await comm.write({"op": "identity", "reply": True})
        return await comm.read()
    except CommClosedError:
        raise
    except Exception as exc:  # noqa: BLE001 (MemoryError, msgpack errors: not dask)
        raise _NotDask(f"{type(exc).__name__}: {str(exc)[:120]}") from None
    finally:
        comm.abort()


def _ask(address: str, timeout: float):
    return asyncio.run(asyncio.wait_for(_identity(address, timeout), timeout))


def check_scheduler(address: str, timeout: float) -> None:
    """A dask scheduler answers at ``address`` within ``timeout`` seconds;
    otherwise ValueError (never a hang: the exchange runs in its own thread
    and event loop and is cancelled at the deadline)."""
    pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="loomfmu-probe")
    try:
        answer = pool.submit(_ask, address, timeout).result(timeout + 5.0)
    except (asyncio.TimeoutError, concurrent.futures.TimeoutError, TimeoutError):
        raise refused(address, f"no dask scheduler answered within {timeout:g} s") from None
    except _NotDask as exc:
        raise refused(address, f"the peer answered with bytes that are not dask's "
                               f"protocol ({exc})") from None
    except Exception as exc:  # noqa: BLE001 (OSError, CommClosedError, a bad scheme)
        raise refused(address, f"no dask scheduler there ({type(exc).__name__}: "
                               f"{str(exc)[:160]})") from None
    finally:
        pool.shutdown(wait=False, cancel_futures=True)
    kind = answer.get("type") if isinstance(answer, dict) else None
    if kind != "Scheduler":
        raise refused(address, f"the peer is not a dask scheduler (it answered as "
                               f"{kind or type(answer).__name__!r:.40})")
