"""Python clients for the xArm command and report ports: sync and async twins over one sans-IO
session (:mod:`.session`), with their methods defined once (:mod:`.helpers`)."""

from .aio import AsyncClient
from .aio import subscribe as subscribe_async
from .common import ClientError, Response
from .session import ReportStream, Session
from .sync import Client, subscribe

__all__ = ["AsyncClient", "Client", "ClientError", "ReportStream", "Response", "Session", "subscribe",
           "subscribe_async"]
