"""Services of the ROS 2 transport: servers and proxies on rclpy.

Part of :mod:`cyborg.transport.ros2`. A request arrives on an executor thread, which waits
while the handler runs on the clock's event loop; a proxy's call is rclpy's asynchronous call,
its answer handed to the loop. rclpy does not say which node sent a request: the sender is the
service's client node when it has one (the graph lists the clients of a service), else ''.
"""

from __future__ import annotations

import asyncio
import inspect
import time
from collections.abc import Awaitable, Callable
from typing import Any, Generic

from rclpy.node import Node as RclNode

from cyborg.errors import ServiceTimeoutError, ServiceUnavailableError, TransportError
from cyborg.transport._host import poll_until
from cyborg.transport.base import MessageInfo, Req, Resp, ServiceProxy, ServiceServer, normalize_node_name
from cyborg.transport.ledger import Channel
from cyborg.transport.messages import ServiceType
from cyborg.transport.ros2.convert import from_ros2, ros2_class, to_ros2
from cyborg.transport.ros2.host import Host

__all__ = ["Ros2ServiceProxy", "Ros2ServiceServer", "only_client"]

HANDLER_LIMIT = 60.0  # seconds a request waits for its handler before the caller gets an empty answer


def only_client(node: RclNode, service: str) -> str:
    """The node calling ``service`` when exactly one node has a client of it, else ''.

    ROS 2 names a service's request topic ``rq/<service>Request``; its publishers are the clients.
    """
    infos = node.get_publishers_info_by_topic(f"rq{service}Request", no_mangle=True)
    names = {normalize_node_name(info.node_name) for info in infos}
    return names.pop() if len(names) == 1 else ""


class Ros2ServiceServer(ServiceServer, Generic[Req, Resp]):
    def __init__(
        self,
        transport: Host,
        node: RclNode,
        name: str,
        srv_type: ServiceType[Req, Resp],
        handler: Callable[[Req, MessageInfo], Resp | Awaitable[Resp]],
        callback_group: Any,
    ) -> None:
        self.name = name
        self._transport = transport
        self._node = node
        self._srv_type = srv_type
        self._handler = handler
        self._srv_cls = ros2_class(srv_type.ros_type, "srv")
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#request", Channel.UNICAST)
        self._service = node.create_service(
            self._srv_cls, name, self._on_request, callback_group=callback_group
        )

    def _on_request(self, ros_request: Any, ros_response: Any) -> Any:  # executor thread
        request = from_ros2(ros_request, self._srv_type.request)
        info = MessageInfo(sender=only_client(self._node, self.name), stamp=time.time())
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
        try:
            response = future.result(timeout=HANDLER_LIMIT)
        except Exception:  # the caller gets an empty answer; the handler's failure is logged on the loop
            future.cancel()
            return ros_response
        return to_ros2(response, self._srv_cls.Response)

    def shutdown(self) -> None:
        self._node.destroy_service(self._service)
        if self._ledger is not None:
            self._ledger.unlisten(f"{self.name}#request")


class Ros2ServiceProxy(ServiceProxy[Req, Resp]):
    def __init__(
        self, transport: Host, node: RclNode, name: str, srv_type: ServiceType[Req, Resp], callback_group: Any
    ) -> None:
        self.name = name
        self._transport = transport
        self._node = node
        self._srv_type = srv_type
        self._srv_cls = ros2_class(srv_type.ros_type, "srv")
        self._client = node.create_client(self._srv_cls, name, callback_group=callback_group)
        self._ledger = transport.clock.ledger
        if self._ledger is not None:
            self._ledger.listen(f"{name}#response", Channel.UNICAST)

    def available(self) -> bool:
        return bool(self._client.service_is_ready())

    async def wait_for_service(self, timeout: float) -> bool:
        """Poll :meth:`available` on the clock (:func:`~cyborg.transport._host.poll_until`)."""
        return await poll_until(self.available, self._transport.clock, timeout)

    async def call(self, request: Req | None = None, *, timeout: float = 5.0) -> Resp:
        req = request if request is not None else self._srv_type.request()
        if not self.available():
            raise ServiceUnavailableError(
                f"service {self.name} is not offered by any node: start the component that offers it"
            )
        loop = self._transport.clock.loop
        answer: asyncio.Future[Any] = loop.create_future()

        ledger = self._ledger

        def done(ros_future: Any) -> None:  # executor thread
            def settle() -> None:
                if ledger is not None:
                    ledger.received(f"{self.name}#response")
                if answer.done():
                    return
                if ros_future.exception() is not None:
                    answer.set_exception(
                        TransportError(f"service {self.name} failed: {ros_future.exception()}")
                    )
                else:
                    answer.set_result(ros_future.result())

            if not loop.is_closed():
                loop.call_soon_threadsafe(settle)

        if ledger is not None:
            ledger.sent(f"{self.name}#request")
        ros_future = self._client.call_async(to_ros2(req, self._srv_cls.Request))
        ros_future.add_done_callback(done)
        self._transport.wake()
        try:
            ros_response = await asyncio.wait_for(answer, timeout)
        except TimeoutError as exc:
            self._client.remove_pending_request(ros_future)
            raise ServiceTimeoutError(
                f"service {self.name} gave no answer within {timeout} s: check that its node is running "
                "and not blocked, or raise the timeout"
            ) from exc
        return from_ros2(ros_response, self._srv_type.response)

    def close(self) -> None:
        self._node.destroy_client(self._client)
