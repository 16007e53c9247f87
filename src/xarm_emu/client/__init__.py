"""Python clients for the xArm command and report ports: sync and async twins."""

from .aio import AsyncClient
from .aio import subscribe as subscribe_async
from .common import ClientError, Response
from .sync import Client, subscribe

__all__ = ["AsyncClient", "Client", "ClientError", "Response", "subscribe", "subscribe_async"]
