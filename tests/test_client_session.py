"""The sans-IO client session: request frames built through the register table, replies matched
by transaction id and decoded, and report frames of section 2.1.6 decoded from a byte stream."""

from __future__ import annotations

import struct

import pytest

from xarm_emu.client import ClientError, ReportStream, Session
from xarm_emu.protocol import reports
from xarm_emu.protocol.frame import STATE_WARNING, encode_reply
from xarm_emu.protocol.registers import BY_NAME

GET_STATE = BY_NAME["GET_STATE"].code
GET_ERROR = BY_NAME["GET_ERROR"].code
SET_MODE = BY_NAME["SET_MODE"].code


def reply(tid: int, register: int, params: bytes = b"", state: int = 0) -> bytes:
    return encode_reply(tid, 2, register, state, params)


def test_request_frames_are_the_manuals_bytes() -> None:
    s = Session()
    # section 2.1.2: tid, protocol 0x0002, length (register + params), register, params
    assert s.request("GET_STATE") == (1, bytes.fromhex("0001 0002 0001 0d"))
    assert s.request(SET_MODE, {"mode": 1}) == (2, bytes.fromhex("0002 0002 0002 13 01"))
    assert s.request("set_mode", raw=b"\x07\x08") == (3, bytes.fromhex("0003 0002 0003 13 0708"))
    assert s.outstanding == 3


def test_transaction_ids_wrap_after_65535() -> None:
    s = Session()
    for _ in range(0xFFFF):
        tid, _frame = s.request(GET_STATE)
    assert tid == 0xFFFF
    tid, frame = s.request(GET_STATE)
    assert tid == 1 and frame[:2] == b"\x00\x01"


def test_replies_are_matched_by_tid_and_decoded_through_the_table() -> None:
    s = Session()
    t1, _ = s.request(GET_STATE)
    t2, _ = s.request(GET_ERROR)
    assert s.next_response() is None
    data = reply(t2, GET_ERROR, bytes((31, 11)), STATE_WARNING) + reply(t1, GET_STATE, b"\x02")
    s.receive_data(data[:5])  # a frame split across reads
    assert s.next_response() is None
    s.receive_data(data[5:])
    first, second = s.next_response(), s.next_response()
    assert first is not None and second is not None
    assert (first.tid, first.register, first.values) == (t2, GET_ERROR, {"error": 31, "warning": 11})
    assert first.has_warning and not first.has_error and first.raw == bytes((31, 11))
    assert (second.tid, second.values) == (t1, {"state": 2})
    assert s.next_response() is None and s.outstanding == 0


def test_a_reply_to_nothing_outstanding_is_dropped() -> None:
    s = Session()
    tid, _ = s.request(GET_STATE)
    s.receive_data(reply(tid + 7, GET_STATE, b"\x01") + reply(tid, GET_STATE, b"\x04"))
    r = s.next_response()
    assert r is not None and r.tid == tid and r["state"] == 4
    assert s.next_response() is None


def test_a_reply_shorter_than_its_layout_keeps_the_bytes_but_no_values() -> None:
    s = Session()
    tid, _ = s.request(GET_ERROR)
    s.receive_data(reply(tid, GET_ERROR, b"\x01"))
    r = s.next_response()
    assert r is not None and r.values == {} and r.raw == b"\x01"


def test_a_reply_of_another_register_is_a_client_error() -> None:
    s = Session()
    tid, _ = s.request(GET_STATE)
    s.receive_data(reply(tid, GET_ERROR, b"\x00\x00"))
    with pytest.raises(ClientError, match="expected 13"):
        s.next_response()


def test_end_of_stream_with_requests_outstanding_is_a_client_error() -> None:
    s = Session()
    s.receive_data(b"")
    assert s.next_response() is None  # nothing was asked
    s.request(GET_STATE)
    with pytest.raises(ClientError, match="closed"):
        s.next_response()


def test_an_unframeable_stream_is_a_client_error() -> None:
    s = Session()
    s.request(GET_STATE)
    with pytest.raises(ClientError, match="length"):
        s.receive_data(bytes.fromhex("0001 0002 0000"))  # length 0


def test_bad_requests_get_clear_answers_and_use_no_tid() -> None:
    s = Session()
    with pytest.raises(KeyError, match="NO_SUCH"):
        s.request("NO_SUCH")
    with pytest.raises(ClientError, match="mode"):
        s.request(SET_MODE)  # the layout's field is missing
    with pytest.raises(ClientError):
        s.request(SET_MODE, {"mode": "fast"})
    assert s.outstanding == 0
    assert s.request(GET_STATE)[0] == 1


def test_report_stream_decodes_each_kind_from_split_and_joined_reads() -> None:
    snap = reports.ReportSnapshot(state=2, mode=1, cmdnum=3, joints=(0.5,) * 7, error=31, warning=11)
    for kind, encode in (("develop", reports.encode_develop), ("normal", reports.encode_normal),
                         ("rich", reports.encode_rich)):
        stream = ReportStream(kind)
        frame = encode(snap)
        stream.receive_data(frame[:3])
        assert stream.next_report() is None
        stream.receive_data(frame[3:] + frame)
        got = [stream.next_report(), stream.next_report()]
        assert stream.next_report() is None
        for s in got:
            assert s is not None and (s.state, s.mode, s.cmdnum) == (2, 1, 3)
            assert s.joints == pytest.approx((0.5,) * 7)
            # the develop report carries no error field; normal and rich do (section 2.1.6)
            assert s.error == (0 if kind == "develop" else 31)


def test_report_stream_refuses_bad_frames_and_reports_the_close() -> None:
    stream = ReportStream("normal")
    stream.receive_data(reports.encode_develop(reports.ReportSnapshot()))  # too short for normal
    with pytest.raises(ClientError, match="normal"):
        stream.next_report()
    stream = ReportStream("develop")
    stream.receive_data(struct.pack(">I", 3))
    with pytest.raises(ClientError, match="length 3"):
        stream.next_report()
    stream = ReportStream("develop")
    stream.receive_data(reports.encode_develop(reports.ReportSnapshot())[:40])
    stream.receive_data(b"")
    with pytest.raises(ClientError, match="closed"):
        stream.next_report()
    with pytest.raises(KeyError, match="fast"):
        ReportStream("fast")
    assert ReportStream("rich").port == reports.RICH_PORT
