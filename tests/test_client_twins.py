"""The sync client and its asyncio twin: call by register name and by code, typed
values, the reply's state bits, and report subscriptions as iterators."""

from __future__ import annotations

import asyncio
import inspect
import math

import pytest

from xarm_emu.client import AsyncClient, Client, ClientError, Response, subscribe, subscribe_async
from xarm_emu.server.app import ServerThread


def test_sync_call_by_name_and_code(server: ServerThread) -> None:
    port = server.ports["command"]
    with Client("127.0.0.1", port) as c:
        by_code = c.call(13)
        by_name = c.call("get_state")
        assert by_code.values == by_name.values == {"state": 4}
        assert by_code.not_ready and not by_code.has_error and not by_code.has_warning
        assert c.get_version() == server.call(lambda: server.emulator.controller.version_string())
        pose = c.get_position()
        assert pose[:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)
        assert abs(abs(pose[3]) - math.pi) < 1e-5
        c.motion_enable(True)
        c.set_mode(0)
        r = c.set_state(0)
        assert not r.not_ready
        assert c.get_state() == 2
        assert c.get_cmdnum() == 0
        server.call(lambda: server.emulator.inject_warning(11))
        r = c.call("GET_ERROR")
        assert r.has_warning and (r["error"], r["warning"]) == (0, 11)
        c.clean_warn()
        assert c.get_err_warn() == (0, 0)
        server.call(lambda: server.emulator.inject_error(31))
        assert c.call(13).has_error
        c.clean_error()
        assert c.get_err_warn() == (0, 0)
        with pytest.raises(KeyError):
            c.call("NO_SUCH_REGISTER")
        # raw parameters bypass the layout: a wrong length gets warning 12 in the state byte
        assert c.call(19, raw=b"").has_warning


def test_async_twin_matches_sync(server: ServerThread) -> None:
    port = server.ports["command"]

    async def main() -> tuple:
        async with await AsyncClient.connect("127.0.0.1", port) as a:
            version = await a.get_version()
            by_name = await a.call("GET_STATE")
            await a.motion_enable(True)
            await a.set_mode(0)
            await a.set_state(0)
            state = await a.get_state()
            joints = await a.get_joints()
            err = await a.get_err_warn()
            # concurrent calls on one connection are serialised, each gets its own reply
            states = await asyncio.gather(*(a.get_state() for _ in range(10)))
            return version, by_name, state, joints, err, states

    version, by_name, state, joints, err, states = asyncio.run(main())
    with Client("127.0.0.1", port) as c:
        assert version == c.get_version()
        assert c.get_joints() == joints
    assert by_name.values == {"state": 4} and by_name.not_ready
    assert state == 2 and err == (0, 0) and states == [2] * 10


def test_sync_subscribe_each_kind(server: ServerThread) -> None:
    for kind in ("develop", "normal", "rich"):
        it = subscribe(kind, "127.0.0.1", server.ports[kind], timeout=2.0)
        try:
            snaps = [next(it) for _ in range(2)]
        finally:
            it.close()
        assert all(s.state == 4 and s.joints == (0.0,) * 7 for s in snaps)
        assert snaps[0].pose[:3] == pytest.approx((207.0, 0.0, 112.0), abs=1e-3)


def test_async_subscribe_follows_the_controller(server: ServerThread) -> None:
    port = server.ports["command"]

    async def main() -> list[int]:
        states = []
        agen = subscribe_async("develop", "127.0.0.1", server.ports["develop"])
        async with await AsyncClient.connect("127.0.0.1", port) as a:
            try:
                async for snap in agen:
                    states.append(snap.state)
                    if len(states) == 1:
                        await a.motion_enable(True)
                        await a.set_mode(0)
                        await a.set_state(0)
                    if snap.state == 2 or len(states) > 100:
                        break
            finally:
                await agen.aclose()
        return states

    states = asyncio.run(main())
    assert states[0] == 4 and states[-1] == 2


def test_client_error_when_the_box_closes(server: ServerThread) -> None:
    c = Client("127.0.0.1", server.ports["command"])
    try:
        c.get_state()
        server.call(server.server.drop_clients)
        with pytest.raises((ClientError, OSError)):
            c.get_state()
    finally:
        c.close()


def _public(cls: type) -> dict[str, object]:
    return {name: getattr(cls, name) for name in dir(cls) if not name.startswith("_")}


def test_twins_have_the_same_public_names_and_signatures() -> None:
    sync, aio = _public(Client), _public(AsyncClient)
    # the async twin connects through a coroutine classmethod instead of its constructor
    assert set(aio) - set(sync) == {"connect"}
    assert set(sync) <= set(aio)
    for name in sorted(set(sync) & set(aio)):
        s, a = sync[name], aio[name]
        assert inspect.iscoroutinefunction(a), name
        assert not inspect.iscoroutinefunction(s), name
        ss, sa = inspect.signature(s), inspect.signature(a)
        assert list(ss.parameters.values()) == list(sa.parameters.values()), name
        assert ss.return_annotation == sa.return_annotation, name
        assert (s.__doc__ or "") == (a.__doc__ or ""), name


def test_every_register_has_a_method_on_both_twins() -> None:
    from xarm_emu.protocol.registers import REGISTERS

    for reg in REGISTERS.values():
        name = reg.name.lower()
        assert not inspect.iscoroutinefunction(getattr(Client, name)), name
        assert inspect.iscoroutinefunction(getattr(AsyncClient, name)), name


def test_typed_helpers_answer_alike_on_both_twins(server: ServerThread) -> None:
    port = server.ports["command"]

    async def run_async() -> list[object]:
        async with await AsyncClient.connect("127.0.0.1", port) as a:
            return await exercise_async(a)

    async def exercise_async(a: AsyncClient) -> list[object]:
        out: list[object] = []
        await a.motion_enable(True)
        await a.set_mode(0)
        await a.set_state(0)
        server.call(lambda: server.emulator.inject_warning(11))
        out.append(await a.get_err_warn())
        out.append((await a.clean_warn()).has_warning)
        out.append(await a.get_err_warn())
        server.call(lambda: server.emulator.inject_error(31))
        out.append(await a.get_err_warn())
        out.append(await a.clean_error())
        out.append(await a.get_err_warn())
        await a.set_state(4)  # stop: the buffer empties
        await a.motion_enable(True)
        await a.set_state(0)
        await a.set_state(3)  # suspended: queued moves stay in the buffer
        for q in (0.1, 0.2):
            await a.move_joint(joints=(q, 0, 0, 0, 0, 0, 0), speed=0.5, acc=5.0, mvtime=0.0)
        out.append(await a.get_cmdnum())
        out.append(await a.get_state())
        await a.set_state(4)
        return out

    def exercise_sync(c: Client) -> list[object]:
        out: list[object] = []
        c.motion_enable(True)
        c.set_mode(0)
        c.set_state(0)
        server.call(lambda: server.emulator.inject_warning(11))
        out.append(c.get_err_warn())
        out.append(c.clean_warn().has_warning)
        out.append(c.get_err_warn())
        server.call(lambda: server.emulator.inject_error(31))
        out.append(c.get_err_warn())
        out.append(c.clean_error())
        out.append(c.get_err_warn())
        c.set_state(4)
        c.motion_enable(True)
        c.set_state(0)
        c.set_state(3)
        for q in (0.1, 0.2):
            c.move_joint(joints=(q, 0, 0, 0, 0, 0, 0), speed=0.5, acc=5.0, mvtime=0.0)
        out.append(c.get_cmdnum())
        out.append(c.get_state())
        c.set_state(4)
        return out

    with Client("127.0.0.1", port) as c:
        from_sync = exercise_sync(c)
    from_async = asyncio.run(run_async())
    for out in (from_sync, from_async):
        warn, _, cleared_warn, err, clean, cleared_err, cmdnum, state = out
        assert warn == (0, 11) and cleared_warn == (0, 0)
        assert err == (31, 0) and cleared_err == (0, 0)
        assert isinstance(clean, Response) and clean.register == 16
        assert cmdnum == 2 and state == 3
    # the same replies, tids aside
    assert [o if not isinstance(o, Response) else (o.register, o.values) for o in from_sync] == \
        [o if not isinstance(o, Response) else (o.register, o.values) for o in from_async]
