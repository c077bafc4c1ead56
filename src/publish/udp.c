// SPDX-License-Identifier: MIT
/*
 * udp.c - UDP unicast and multicast, IPv4 or IPv6. One unconnected,
 * non-blocking socket; a cycle's messages leave in one sendmmsg() call
 * whose headers were allocated at open(). An unconnected socket also
 * means a receiver that is not there costs nothing (no ICMP errors come
 * back as send failures).
 */
#include "publish/output.h"

#include "avatargw/wire.h"

#include <arpa/inet.h>
#include <errno.h>
#include <net/if.h>
#include <netdb.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define UDP_BATCH 1024 /* UIO_MAXIOV: messages per sendmmsg() */

struct udp {
	int fd;
	struct sockaddr_storage dst;
	socklen_t dst_len;
	struct mmsghdr *mm;
	struct iovec *iov;
	int cap;
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
	int ttl = cfg->ttl, loop = cfg->mcast_loop;
	unsigned ifindex = 0;

	if (cfg->interface[0]) {
		ifindex = if_nametoindex(cfg->interface);
		if (!ifindex) {
			snprintf(err, errlen, "[output %s] interface: %s: %s", cfg->name, cfg->interface,
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

	snprintf(port, sizeof(port), "%d", cfg->port);
	rc = getaddrinfo(cfg->address, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[output %s] address: %s: %s", cfg->name, cfg->address, gai_strerror(rc));
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
	if ((cfg->type == CFG_OUT_MULTICAST) != is_multicast((struct sockaddr *)&u->dst)) {
		snprintf(err, errlen, "[output %s] address: %s is %sa multicast address: use type = %s", cfg->name,
			 cfg->address, cfg->type == CFG_OUT_MULTICAST ? "not " : "",
			 cfg->type == CFG_OUT_MULTICAST ? "udp" : "multicast");
		free(u);
		return -EINVAL;
	}
	u->fd = socket(u->dst.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (u->fd < 0) {
		snprintf(err, errlen, "[output %s]: socket: %s", cfg->name, strerror(errno));
		free(u);
		return -errno;
	}
	if (cfg->type == CFG_OUT_MULTICAST && (rc = set_multicast(u, cfg, err, errlen))) {
		close(u->fd);
		free(u);
		return rc;
	}
	/* a frame and a DESCRIBE per avatar at most per cycle */
	u->cap = 2 * o->n_avatars + 2;
	u->mm = calloc((size_t)u->cap, sizeof(*u->mm));
	u->iov = calloc((size_t)u->cap, sizeof(*u->iov));
	if (!u->mm || !u->iov) {
		close(u->fd);
		free(u->mm);
		free(u->iov);
		free(u);
		return -ENOMEM;
	}
	for (int i = 0; i < u->cap; i++) {
		u->mm[i].msg_hdr.msg_name = &u->dst;
		u->mm[i].msg_hdr.msg_namelen = u->dst_len;
		u->mm[i].msg_hdr.msg_iov = &u->iov[i];
		u->mm[i].msg_hdr.msg_iovlen = 1;
	}
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
	free(u);
	o->priv = NULL;
}

static void udp_send(struct output *o, const struct out_msg *m, int n)
{
	struct udp *u = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	int k = 0, i = 0;

	o->cycle++;
	for (int j = 0; j < n && k < u->cap; j++) {
		if (!o->wants[m[j].avatar] || (!frames && m[j].data[5] == WIRE_FRAME))
			continue;
		u->iov[k].iov_base = (void *)m[j].data;
		u->iov[k].iov_len = m[j].len;
		k++;
	}
	while (i < k) {
		int chunk = k - i > UDP_BATCH ? UDP_BATCH : k - i;
		int rc = sendmmsg(u->fd, &u->mm[i], (unsigned)chunk, MSG_DONTWAIT);

		if (rc > 0) {
			ctr_add_out(&o->st.sent, (uint64_t)rc);
			i += rc;
			continue;
		}
		if (rc < 0 && errno == EINTR)
			continue;
		/* the message at i could not go: drop it, carry on with the next */
		if (rc < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS)) {
			ctr_add_out(&o->st.dropped, 1);
		} else {
			ctr_add_out(&o->st.errors, 1);
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
	.open = udp_open,
	.close = udp_close,
	.send = udp_send,
	.service = udp_service,
};
