"""Services of the ROS 1 transport: servers and proxies on rospy.

Part of :mod:`cyborg.transport.ros`. A request arrives on a rospy thread, which waits while the
handler runs on the clock's event loop; a proxy's call waits in an executor thread, so the loop
runs on meanwhile.
"""

from __future__ import annotations

import asyncio
import inspect
import time
from collections.abc import Awaitable, Callable
from typing import Any, Generic

import rospy  # type: ignore[import-not-found]

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport._host import Host
from cyborg.transport.base import MessageInfo, Req, Resp, ServiceProxy, ServiceServer
from cyborg.transport.ledger import Channel
from cyborg.transport.messages import ServiceType
from cyborg.transport.ros.convert import from_ros, ros_class, sender, to_ros

__all__ = ["RosServiceProxy", "RosServiceServer"]


class RosServiceServer(ServiceServer, Generic[Req, Resp]):
    def __init__(
        self,
        transport: Host,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
    ) -> None:
        self.name = name
        self._transport = transport
        self._srv_type = srv_type
        self._handler = handler
        self._srv_cls = ros_class(srv_type.ros_type, "srv")
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#request", Channel.UNICAST)
        self._service = rospy.Service(name, self._srv_cls, self._on_request)

    def _on_request(self, ros_request: Any) -> Any:  # rospy thread
        request = from_ros(ros_request, self._srv_type.request)
        info = MessageInfo(sender=sender(ros_request), stamp=time.time())

        ledger = self._ledger

        async def answer() -> Resp:
            if ledger is not None:
                ledger.received(f"{self.name}#request")
            try:
                result = self._handler(request, info)
                if inspect.isawaitable(result):
                    result = await result
                return result  # type: ignore[return-value]
            finally:
                if ledger is not None:
                    ledger.sent(f"{self.name}#response")

        future = asyncio.run_coroutine_threadsafe(answer(), self._transport.clock.loop)
        response = future.result(timeout=60.0)
        return to_ros(response, self._srv_cls._response_class)

    def shutdown(self) -> None:
        self._service.shutdown("node shutting down")
        if self._ledger is not None:
            self._ledger.unlisten(f"{self.name}#request")


class RosServiceProxy(ServiceProxy[Req, Resp]):
    def __init__(self, transport: Host, name: str, srv_type: ServiceType[Req, Resp]) -> None:
        self.name = name
        self._transport = transport
        self._srv_type = srv_type
        self._srv_cls = ros_class(srv_type.ros_type, "srv")
        self._proxy = rospy.ServiceProxy(name, self._srv_cls)
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#response", Channel.UNICAST)

    def available(self) -> bool:
        try:
            rospy.wait_for_service(self.name, timeout=0.05)
        except rospy.ROSException:
            return False
        return True

    async def wait_for_service(self, timeout: float) -> bool:
        loop = asyncio.get_running_loop()
        try:
            with self._transport.clock.hold():
                await loop.run_in_executor(
                    None, lambda: rospy.wait_for_service(self.name, timeout=max(timeout, 0.01))
                )
        except rospy.ROSException:
            return False
        return True

    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        loop = asyncio.get_running_loop()
        req = request if request is not None else self._srv_type.request()
        with self._transport.clock.hold():  # finding the service takes real time, not virtual
            available = await loop.run_in_executor(None, self.available)
        if not available:
            raise ServiceUnavailableError(
                f"service {self.name} is not offered by any node: start the component that offers it"
            )
        ros_request = to_ros(req, self._srv_cls._request_class)
        ledger = self._ledger
        if ledger is not None:
            ledger.sent(f"{self.name}#request")
        try:
            try:
                ros_response = await asyncio.wait_for(
                    loop.run_in_executor(None, self._proxy.call, ros_request), timeout
                )
            finally:
                if ledger is not None:
                    ledger.received(f"{self.name}#response")
        except TimeoutError as exc:
            raise ServiceTimeoutError(
                f"service {self.name} gave no answer within {timeout} s: check that its node is running "
                "and not blocked, or raise the timeout"
            ) from exc
        except rospy.ServiceException as exc:
            raise TransportError(f"service {self.name} failed: {exc}") from exc
        return from_ros(ros_response, self._srv_type.response)
