// SPDX-License-Identifier: MIT
/*
 * udp.c - UDP unicast and multicast, IPv4 or IPv6. One unconnected,
 * non-blocking socket; a cycle's messages leave in one sendmmsg() call
 * whose headers were allocated at open(). An unconnected socket also
 * means a receiver that is not there costs nothing (no ICMP errors come
 * back as send failures).
 *
 * Generic segmentation offload (UDP_SEGMENT, Linux 4.18): consecutive
 * messages of the same length (the FRAMEs of many avatars, 500 bytes each)
 * go down the stack as one buffer that the kernel cuts into datagrams of
 * that length at the last moment. Receivers see ordinary datagrams, each
 * still one message; the sender pays for one trip through the stack per
 * run instead of one per datagram (about 3x less CPU per datagram on
 * loopback, see docs/DAEMON.md). A kernel or path that refuses it (no
 * UDP_SEGMENT, IPsec, a device without checksum offload) turns it off for
 * good at the first refusal, and the messages go one per datagram.
 */
#include "publish/output.h"
#include "publish/udp.h"

#include "avatargw/wire.h"

#include <arpa/inet.h>
#include <errno.h>
#include <net/if.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <netinet/udp.h>
#include <sys/socket.h>
#include <unistd.h>

/* the keys its types share (read before each type's own) */
static const struct cfg_key udp_shared_keys[] = {
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct udp_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "7770",
	  .doc = "UDP port to send to" },
	{ .name = "gso",
	  .kind = CFG_BOOL,
	  CFG_AT(struct udp_opts, gso),
	  .def = "yes",
	  .doc = "send runs of equal-length messages as one buffer the kernel cuts into datagrams (UDP_SEGMENT); "
		 "off by itself where refused" },
};

static const struct cfg_key udp_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct udp_opts, address),
	  .def = "127.0.0.1",
	  .doc = "host name or address to send to" },
};

static const struct cfg_key multicast_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct udp_opts, address),
	  .missing = "a multicast group",
	  .doc = "multicast group to send to (239.255.77.70 or ff15::7770 style)" },
	{ .name = "interface",
	  .kind = CFG_STR,
	  CFG_AT(struct udp_opts, interface),
	  .def = "",
	  .doc = "network interface to send from (empty: the kernel's choice)" },
	{ .name = "ttl",
	  .kind = CFG_INT,
	  CFG_AT(struct udp_opts, ttl),
	  .min = 0,
	  .max = 255,
	  .def = "1",
	  .doc = "multicast hop limit" },
	{ .name = "loopback",
	  .kind = CFG_BOOL,
	  CFG_AT(struct udp_opts, mcast_loop),
	  .def = "yes",
	  .doc = "deliver multicast to listeners on this host too" },
};

static const struct udp_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

#ifndef UDP_SEGMENT
#define UDP_SEGMENT 103
#endif
#ifndef SOL_UDP
#define SOL_UDP 17
#endif

#define UDP_BATCH 1024	    /* UIO_MAXIOV: headers per sendmmsg() */
#define UDP_GSO_SEGS 64	    /* UDP_MAX_SEGMENTS of every kernel that has UDP_SEGMENT */
#define UDP_GSO_BYTES 60000 /* one GSO buffer stays below the 64 KiB datagram limit */

struct udp {
	int fd;
	struct sockaddr_storage dst;
	socklen_t dst_len;
	struct mmsghdr *mm;
	struct iovec *iov;
	uint16_t *segs; /* messages carried by mm[i] */
	union udp_cmsg {
		char buf[CMSG_SPACE(sizeof(uint16_t))];
		struct cmsghdr align;
	} * cmsg;
	int cap;
	bool gso;
};

static bool is_multicast(const struct sockaddr *sa)
{
	if (sa->sa_family == AF_INET)
		return IN_MULTICAST(ntohl(((const struct sockaddr_in *)sa)->sin_addr.s_addr));
	if (sa->sa_family == AF_INET6)
		return IN6_IS_ADDR_MULTICAST(&((const struct sockaddr_in6 *)sa)->sin6_addr);
	return false;
}

static int set_multicast(struct udp *u, const struct cfg_output *cfg, char *err, size_t errlen)
{
	int ttl = opts_of(cfg)->ttl, loop = opts_of(cfg)->mcast_loop;
	unsigned ifindex = 0;

	if (opts_of(cfg)->interface[0]) {
		ifindex = if_nametoindex(opts_of(cfg)->interface);
		if (!ifindex) {
			snprintf(err, errlen, "[output %s] interface: %s: %s", cfg->name, opts_of(cfg)->interface,
				 strerror(errno));
			return -ENODEV;
		}
	}
	if (u->dst.ss_family == AF_INET) {
		unsigned char t = (unsigned char)ttl, l = (unsigned char)loop;

		if (setsockopt(u->fd, IPPROTO_IP, IP_MULTICAST_TTL, &t, sizeof(t)) ||
		    setsockopt(u->fd, IPPROTO_IP, IP_MULTICAST_LOOP, &l, sizeof(l)))
			goto fail;
		if (ifindex) {
			struct ip_mreqn mr = { .imr_ifindex = (int)ifindex };

			if (setsockopt(u->fd, IPPROTO_IP, IP_MULTICAST_IF, &mr, sizeof(mr)))
				goto fail;
		}
	} else {
		if (setsockopt(u->fd, IPPROTO_IPV6, IPV6_MULTICAST_HOPS, &ttl, sizeof(ttl)) ||
		    setsockopt(u->fd, IPPROTO_IPV6, IPV6_MULTICAST_LOOP, &loop, sizeof(loop)))
			goto fail;
		if (ifindex && setsockopt(u->fd, IPPROTO_IPV6, IPV6_MULTICAST_IF, &ifindex, sizeof(ifindex)))
			goto fail;
	}
	return 0;
fail:
	snprintf(err, errlen, "[output %s]: multicast options: %s", cfg->name, strerror(errno));
	return -errno;
}

static int udp_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct addrinfo hints = { .ai_socktype = SOCK_DGRAM, .ai_flags = AI_NUMERICSERV }, *ai;
	char port[8];
	struct udp *u;
	int rc;

	snprintf(port, sizeof(port), "%d", opts_of(cfg)->port);
	rc = getaddrinfo(opts_of(cfg)->address, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[output %s] address: %s: %s", cfg->name, opts_of(cfg)->address,
			 gai_strerror(rc));
		return -EINVAL;
	}
	u = calloc(1, sizeof(*u));
	if (!u) {
		freeaddrinfo(ai);
		return -ENOMEM;
	}
	memcpy(&u->dst, ai->ai_addr, ai->ai_addrlen);
	u->dst_len = ai->ai_addrlen;
	freeaddrinfo(ai);
	if ((cfg_output_is(cfg, "multicast")) != is_multicast((struct sockaddr *)&u->dst)) {
		snprintf(err, errlen, "[output %s] address: %s is %sa multicast address: use type = %s", cfg->name,
			 opts_of(cfg)->address, cfg_output_is(cfg, "multicast") ? "not " : "",
			 cfg_output_is(cfg, "multicast") ? "udp" : "multicast");
		free(u);
		return -EINVAL;
	}
	u->fd = socket(u->dst.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (u->fd < 0) {
		snprintf(err, errlen, "[output %s]: socket: %s", cfg->name, strerror(errno));
		free(u);
		return -errno;
	}
	if (cfg_output_is(cfg, "multicast") && (rc = set_multicast(u, cfg, err, errlen))) {
		close(u->fd);
		free(u);
		return rc;
	}
	/* a frame and a DESCRIBE per avatar at most per cycle */
	u->cap = 2 * o->n_avatars + 2;
	u->mm = calloc((size_t)u->cap, sizeof(*u->mm));
	u->iov = calloc((size_t)u->cap, sizeof(*u->iov));
	u->segs = calloc((size_t)u->cap, sizeof(*u->segs));
	u->cmsg = calloc((size_t)u->cap, sizeof(*u->cmsg));
	if (!u->mm || !u->iov || !u->segs || !u->cmsg) {
		close(u->fd);
		free(u->mm);
		free(u->iov);
		free(u->segs);
		free(u->cmsg);
		free(u);
		return -ENOMEM;
	}
	for (int i = 0; i < u->cap; i++) {
		struct cmsghdr *c = (struct cmsghdr *)u->cmsg[i].buf;

		u->mm[i].msg_hdr.msg_name = &u->dst;
		u->mm[i].msg_hdr.msg_namelen = u->dst_len;
		c->cmsg_level = SOL_UDP;
		c->cmsg_type = UDP_SEGMENT;
		c->cmsg_len = CMSG_LEN(sizeof(uint16_t));
	}
	u->gso = opts_of(cfg)->gso;
	o->priv = u;
	return 0;
}

static void udp_close(struct output *o)
{
	struct udp *u = o->priv;

	if (!u)
		return;
	close(u->fd);
	free(u->mm);
	free(u->iov);
	free(u->segs);
	free(u->cmsg);
	free(u);
	o->priv = NULL;
}

/*
 * Builds the headers for messages iov[0..k): one per run of equal lengths
 * when GSO is on, one per message otherwise. Returns the number of headers.
 */
static int udp_build(struct udp *u, int k)
{
	int h = 0;

	for (int i = 0; i < k; h++) {
		struct msghdr *mh = &u->mm[h].msg_hdr;
		size_t len = u->iov[i].iov_len;
		int run = 1;

		if (u->gso)
			while (i + run < k && run < UDP_GSO_SEGS && u->iov[i + run].iov_len == len &&
			       (size_t)(run + 1) * len <= UDP_GSO_BYTES)
				run++;
		mh->msg_iov = &u->iov[i];
		mh->msg_iovlen = (size_t)run;
		if (run > 1) {
			uint16_t seg = (uint16_t)len;

			memcpy(CMSG_DATA((struct cmsghdr *)u->cmsg[h].buf), &seg, sizeof(seg));
			mh->msg_control = u->cmsg[h].buf;
			mh->msg_controllen = sizeof(u->cmsg[h].buf);
		} else {
			mh->msg_control = NULL;
			mh->msg_controllen = 0;
		}
		u->segs[h] = (uint16_t)run;
		i += run;
	}
	return h;
}

static bool gso_refused(int e)
{
	/* no UDP_SEGMENT, or a path that cannot segment (no checksum offload, IPsec) */
	return e == EINVAL || e == ENOPROTOOPT || e == EIO || e == EOPNOTSUPP;
}

static void udp_send(struct output *o, const struct out_msg *m, int n)
{
	struct udp *u = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	int k = 0, i = 0, h;

	o->cycle++;
	for (int j = 0; j < n && k < u->cap; j++) {
		if (!o->wants[m[j].avatar] || (!frames && m[j].type == WIRE_FRAME))
			continue;
		u->iov[k].iov_base = (void *)m[j].data;
		u->iov[k].iov_len = m[j].len;
		k++;
	}
	h = udp_build(u, k);
	while (i < h) {
		int chunk = h - i > UDP_BATCH ? UDP_BATCH : h - i;
		int rc = sendmmsg(u->fd, &u->mm[i], (unsigned)chunk, MSG_DONTWAIT);

		if (rc > 0) {
			for (int j = i; j < i + rc; j++)
				ctr_add(&o->st.sent, u->segs[j]);
			i += rc;
			continue;
		}
		if (rc < 0 && errno == EINTR)
			continue;
		if (rc < 0 && u->segs[i] > 1 && gso_refused(errno)) {
			/* rebuild what is left one message per header, and never try again */
			int left = 0;

			for (int j = i; j < h; j++)
				left += u->segs[j];
			memmove(u->iov, u->mm[i].msg_hdr.msg_iov, (size_t)left * sizeof(*u->iov));
			u->gso = false;
			ctr_add(&o->st.gso_off, 1);
			h = udp_build(u, left);
			i = 0;
			continue;
		}
		/* the message(s) at i could not go: drop them, carry on with the next */
		if (rc < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) {
			ctr_add(&o->st.dropped, u->segs[i]);
		} else {
			ctr_add(&o->st.errors, u->segs[i]);
			atomic_store_explicit(&o->st.last_errno, rc < 0 ? errno : EIO, memory_order_relaxed);
		}
		i++;
	}
}

static void udp_service(struct output *o)
{
	(void)o;
}

const struct output_ops udp_output_ops = {
	.type = { CFG_TYPE("udp", "UDP datagrams to one address (protocol v1)", udp_keys, struct udp_opts),
		  CFG_SHARED(udp_shared_keys) },
	.open = udp_open,
	.close = udp_close,
	.send = udp_send,
	.service = udp_service,
};

const struct output_ops multicast_output_ops = {
	.type = { CFG_TYPE("multicast", "UDP datagrams to a multicast group (a CAVE cluster)", multicast_keys,
			   struct udp_opts),
		  CFG_SHARED(udp_shared_keys) },
	.open = udp_open,
	.close = udp_close,
	.send = udp_send,
	.service = udp_service,
};
