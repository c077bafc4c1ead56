// SPDX-License-Identifier: MIT
/*
 * can_port.c - see can_port.h.
 */
#include "wire/can_port.h"

#include <errno.h>
#include <fcntl.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

static int open_inherited(struct can_port *p, const char *num, char *err, size_t errlen)
{
	char *end;
	long n;
	int fd;

	errno = 0;
	n = strtol(num, &end, 10);
	if (!num[0] || *end || errno || n < 0 || n > 65535) {
		snprintf(err, errlen, "fd:%s: not a descriptor number", num);
		return -EINVAL;
	}
	/* a duplicate of our own: a reload opens the port again before closing the old one */
	fd = fcntl((int)n, F_DUPFD_CLOEXEC, 3);
	if (fd < 0) {
		int rc = -errno;

		snprintf(err, errlen, "fd:%ld: %s", n, strerror(errno));
		return rc;
	}
	if (fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK)) {
		int rc = -errno;

		snprintf(err, errlen, "fd:%ld: %s", n, strerror(errno));
		close(fd);
		return rc;
	}
	p->fd = fd;
	p->is_can = false;
	return 0;
}

int can_port_open(struct can_port *p, const char *iface, bool rx, char *err, size_t errlen)
{
	struct sockaddr_can addr = { .can_family = AF_CAN };
	unsigned idx;
	int fd, rc;

	p->fd = -1;
	p->is_can = false;
	if (!strncmp(iface, "fd:", 3))
		return open_inherited(p, iface + 3, err, errlen);
	fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
	if (fd < 0) {
		rc = -errno;
		if (rc == -EAFNOSUPPORT)
			snprintf(err, errlen, "%s: this kernel has no CAN support (socket(PF_CAN): %s)", iface,
				 strerror(errno));
		else
			snprintf(err, errlen, "%s: socket(PF_CAN): %s", iface, strerror(errno));
		return rc;
	}
	idx = if_nametoindex(iface);
	if (!idx) {
		rc = errno == ENXIO || errno == ENODEV ? -ENODEV : -errno;
		snprintf(err, errlen, "%s: no such CAN interface (%s)", iface, strerror(errno));
		close(fd);
		return rc;
	}
	addr.can_ifindex = (int)idx;
	/* an output reads nothing: no filter, no receive queue filling with the bus's traffic */
	if (!rx && setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, NULL, 0)) {
		rc = -errno;
		snprintf(err, errlen, "%s: CAN_RAW_FILTER: %s", iface, strerror(errno));
		close(fd);
		return rc;
	}
	if (bind(fd, (struct sockaddr *)&addr, sizeof(addr))) {
		rc = -errno;
		snprintf(err, errlen, "%s: bind: %s", iface, strerror(errno));
		close(fd);
		return rc;
	}
	p->fd = fd;
	p->is_can = true;
	return 0;
}

void can_port_close(struct can_port *p)
{
	if (p->fd >= 0)
		close(p->fd);
	p->fd = -1;
}

int can_port_send(struct can_port *p, const struct can_frame *f)
{
	for (;;) {
		ssize_t n = send(p->fd, f, sizeof(*f), MSG_DONTWAIT | MSG_NOSIGNAL);

		if (n == (ssize_t)sizeof(*f))
			return 0;
		if (n >= 0)
			return -EIO;
		if (errno == EINTR)
			continue;
		return errno == EWOULDBLOCK ? -EAGAIN : -errno;
	}
}

int can_port_recv(struct can_port *p, struct can_frame *f)
{
	/* room for a CAN FD frame: one that arrives is read whole and refused, not split */
	union {
		struct can_frame cf;
		struct canfd_frame fd;
	} u;

	for (;;) {
		ssize_t n = recv(p->fd, &u, sizeof(u), MSG_DONTWAIT);

		if (n == (ssize_t)sizeof(u.cf)) {
			*f = u.cf;
			/* a length beyond 8 (a raw DLC of 9..15) is not one of ours to trust */
			return f->len <= CAN_MAX_DLEN ? 1 : -EMSGSIZE;
		}
		if (n >= 0)
			return n == 0 && !p->is_can ? -EPIPE : -EMSGSIZE;
		if (errno == EINTR)
			continue;
		if (errno == EAGAIN || errno == EWOULDBLOCK)
			return 0;
		return -errno;
	}
}
