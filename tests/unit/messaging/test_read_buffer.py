"""paho's socket read through a buffer (messaging/read_buffer.py): what paho asks for is what it
gets, in order, whatever the sizes and however the bytes arrive; the socket's own end, errors
and options pass through."""

from __future__ import annotations

import socket

import pytest

from dronefleet.messaging.read_buffer import READ_BYTES, BufferedSocket


class Counting:
    """A socket that counts its recv calls."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock, self.reads = sock, 0

    def recv(self, size: int) -> bytes:
        self.reads += 1
        return self.sock.recv(size)

    def __getattr__(self, name: str):
        return getattr(self.sock, name)


@pytest.fixture
def pair():
    a, b = socket.socketpair()
    b.setblocking(False)
    yield a, b
    a.close()
    b.close()


def test_many_small_reads_take_one_system_call_and_come_out_in_order(pair) -> None:
    sender, receiver = pair
    data = bytes(range(256)) * 40  # 10,240 bytes
    sender.sendall(data)
    counting = Counting(receiver)
    buffered = BufferedSocket(counting)
    got = []
    sizes = [1, 1, 2, 300, 1, 5000, 17]
    for size in sizes:
        got.append(buffered.recv(size))
    assert [len(g) for g in got] == sizes
    assert b"".join(got) == data[: sum(sizes)]
    assert counting.reads == 1
    assert buffered.pending() == len(data) - sum(sizes)


def test_a_read_beyond_what_is_held_is_short_and_the_next_reads_the_socket(pair) -> None:
    sender, receiver = pair
    sender.sendall(b"abcdef")
    buffered = BufferedSocket(receiver)
    assert buffered.recv(2) == b"ab"
    assert buffered.recv(100) == b"cdef"  # only what is held: a short read, as recv may give
    assert buffered.pending() == 0
    with pytest.raises(BlockingIOError):  # nothing more: paho's "try again later"
        buffered.recv(1)
    sender.sendall(b"gh")
    assert buffered.recv(1) == b"g" and buffered.recv(1) == b"h"


def test_a_packet_larger_than_a_read_comes_whole_across_reads(pair) -> None:
    sender, receiver = pair
    receiver.setblocking(True)
    big = bytes(i % 251 for i in range(3 * READ_BYTES + 123))
    sender.sendall(b"\x30" + big[:100])
    buffered = BufferedSocket(receiver)
    assert buffered.recv(1) == b"\x30"
    parts, wanted = [], len(big)
    sender.sendall(big[100:])
    while wanted:  # paho reads the rest of a packet until it has all of it
        part = buffered.recv(wanted)
        assert part
        parts.append(part)
        wanted -= len(part)
    assert b"".join(parts) == big


def test_the_end_of_the_stream_is_an_empty_read(pair) -> None:
    sender, receiver = pair
    sender.sendall(b"xy")
    sender.close()
    buffered = BufferedSocket(receiver)
    assert buffered.recv(1) == b"x"
    assert buffered.recv(1) == b"y"
    assert buffered.recv(1) == b""


def test_what_paho_and_aiomqtt_use_of_the_socket_is_the_sockets(pair) -> None:
    _, receiver = pair
    buffered = BufferedSocket(receiver)
    assert buffered.fileno() == receiver.fileno()
    buffered.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    assert receiver.getsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE) == 1
    buffered.setblocking(True)
    assert receiver.getblocking()
    buffered.close()
    assert receiver.fileno() == -1


def test_the_rest_of_a_packet_is_read_alone_so_a_turn_ends_with_it(pair) -> None:
    """A read ahead for a packet's rest would take the next packets too: one connection's
    backlog read whole in one turn of the event loop, the others waiting."""
    sender, receiver = pair
    sender.sendall(b"\x30" + b"a" * 99)
    buffered = BufferedSocket(receiver)
    assert buffered.recv(1) == b"\x30"  # a packet's first byte: read ahead
    assert buffered.recv(200) == b"a" * 99  # what is held of it (a short read)
    sender.sendall(b"b" * 101 + b"\x30next")  # its rest, then the next packet
    assert buffered.recv(101) == b"b" * 101
    assert buffered.pending() == 0  # the turn ends: the next packet waits for the next one
    assert buffered.recv(1) == b"\x30" and buffered.pending() == 4
