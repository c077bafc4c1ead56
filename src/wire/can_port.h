/* SPDX-License-Identifier: MIT */
/*
 * can_port.h - a SocketCAN raw socket behind a file descriptor, so that
 * everything above it runs the same over a real interface, vcan, or one end
 * of a socketpair(AF_UNIX, SOCK_SEQPACKET) carrying struct can_frame records
 * (which is how the tests drive it on a kernel without CAN).
 *
 * Non-blocking throughout; never allocates after can_port_open().
 */
#ifndef AGW_CAN_PORT_H
#define AGW_CAN_PORT_H

#include <linux/can.h>
#include <stdbool.h>
#include <stddef.h>

struct can_port {
	int fd;	     /* -1: closed */
	bool is_can; /* a PF_CAN socket (else an inherited descriptor) */
};

/*
 * Opens iface: a PF_CAN raw socket bound to that interface, or, for
 * "fd:N", a duplicate of the inherited descriptor N (the caller keeps N).
 * rx: the port reads frames (without it a CAN socket receives nothing).
 * 0, or a negative errno with err saying what failed: -EAFNOSUPPORT when
 * the kernel has no CAN, -ENODEV when the interface does not exist.
 */
int can_port_open(struct can_port *p, const char *iface, bool rx, char *err, size_t errlen);
void can_port_close(struct can_port *p);
/* 0 sent; -EAGAIN or -ENOBUFS: the queue is full, the frame was not sent; another negative errno */
int can_port_send(struct can_port *p, const struct can_frame *f);
/*
 * 1: a frame in f; 0: nothing waiting; -EMSGSIZE: a record that is not a
 * classic CAN frame (a CAN FD frame, a short write) was read and dropped;
 * another negative errno on failure.
 */
int can_port_recv(struct can_port *p, struct can_frame *f);

#endif /* AGW_CAN_PORT_H */
