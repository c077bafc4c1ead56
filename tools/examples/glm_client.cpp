// SPDX-License-Identifier: MIT
/*
 * glm_client.cpp - a small avatargw client in C++17 with GLM as the math.
 *
 * It shows what a renderer integration (Unity, Unreal, your own engine) has
 * to do with the protocol of docs/PROTOCOL.md:
 *
 *   1. receive UDP datagrams (unicast or a multicast group);
 *   2. keep each avatar's DESCRIBE: the joints' axes and translations;
 *   3. for every FRAME, rebuild the bones of both arms from the chest pose
 *      and the joint angles, one glm::rotate and one glm::translate per
 *      joint;
 *   4. here, instead of drawing them, compare the rebuilt bones with the
 *      segment poses the daemon published in the same FRAME.
 *
 * If the two agree, a client that animates a rig from the joint angles
 * shows exactly what the daemon solved. Exit status with --count N: 0 if
 * every segment of every frame with finite angles agreed within the
 * tolerances, 1 otherwise (the worst disagreement is printed).
 *
 * Only avatargw/wire.h (and its wire.c, for the decoders) is used from the
 * project; everything else is GLM and POSIX sockets.
 */
#include <glm/glm.hpp>
#include <glm/gtc/matrix_transform.hpp> // glm::rotate, glm::translate
#include <glm/gtc/quaternion.hpp>	// glm::quat, glm::mat4_cast, glm::quat_cast

#include <arpa/inet.h>
#include <net/if.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

#include "avatargw/wire.h"

namespace
{

/* ---- options ------------------------------------------------------------------- */

struct options {
	int port = WIRE_DEFAULT_PORT;
	std::string group;     // multicast group to join, empty: unicast
	std::string iface;     // interface for the group, empty: the kernel's choice
	long count = 0;	       // frames to check, 0: until SIGINT
	double tol_pos = 1e-4; // metres
	double tol_rot = 1e-3; // radians
	long avatar = -1;      // -1: every avatar
	double timeout = 0;    // seconds without a datagram before giving up, 0: never
	bool quiet = false;    // summary only
};

void usage(FILE *f)
{
	std::fprintf(f,
		     "usage: glm_client [--port N] [--group ADDR [--interface IF]] [--count N]\n"
		     "                  [--tol-pos M] [--tol-rot RAD] [--avatar ID] [--timeout S] [--quiet]\n"
		     "\n"
		     "Rebuilds every arm bone from the joint angles and the DESCRIBE with GLM and\n"
		     "compares it with the segment poses of the same FRAME.\n"
		     "  --port N        UDP port (default %d)\n"
		     "  --group ADDR    join this IPv4 or IPv6 multicast group\n"
		     "  --interface IF  network interface for the group\n"
		     "  --count N       stop after N checked frames; status 0 if all agreed\n"
		     "  --tol-pos M     position tolerance, metres (default 1e-4)\n"
		     "  --tol-rot RAD   rotation tolerance, radians (default 1e-3)\n"
		     "  --avatar ID     only this avatar\n"
		     "  --timeout S     exit 1 if no datagram arrives for S seconds\n"
		     "  --quiet         no line per frame, only the summary\n",
		     WIRE_DEFAULT_PORT);
}

bool parse(int argc, char **argv, options &o)
{
	for (int i = 1; i < argc; i++) {
		std::string a = argv[i];
		const char *v = i + 1 < argc ? argv[i + 1] : nullptr;
		bool takes = a == "--port" || a == "--group" || a == "--interface" || a == "--count" ||
			     a == "--tol-pos" || a == "--tol-rot" || a == "--avatar" || a == "--timeout";

		if (takes && !v) {
			std::fprintf(stderr, "glm_client: %s needs a value\n", a.c_str());
			return false;
		}
		if (a == "--port")
			o.port = std::atoi(v);
		else if (a == "--group")
			o.group = v;
		else if (a == "--interface")
			o.iface = v;
		else if (a == "--count")
			o.count = std::atol(v);
		else if (a == "--tol-pos")
			o.tol_pos = std::atof(v);
		else if (a == "--tol-rot")
			o.tol_rot = std::atof(v);
		else if (a == "--avatar")
			o.avatar = std::atol(v);
		else if (a == "--timeout")
			o.timeout = std::atof(v);
		else if (a == "--quiet")
			o.quiet = true;
		else if (a == "--help") {
			usage(stdout);
			std::exit(0);
		} else {
			usage(stderr);
			return false;
		}
		if (takes)
			i++;
	}
	if (o.port <= 0 || o.port > 65535 || o.count < 0 || !(o.tol_pos > 0) || !(o.tol_rot > 0)) {
		std::fprintf(stderr, "glm_client: bad --port, --count or tolerance\n");
		return false;
	}
	return true;
}

/* ---- the socket -------------------------------------------------------------------- */

/* a UDP socket on the port, member of the group if there is one; -1 on error */
int open_udp(const options &o)
{
	int family = AF_INET;
	addrinfo *group = nullptr;

	if (!o.group.empty()) {
		addrinfo hints{};
		hints.ai_socktype = SOCK_DGRAM;
		hints.ai_flags = AI_NUMERICHOST;
		if (getaddrinfo(o.group.c_str(), nullptr, &hints, &group) != 0) {
			std::fprintf(stderr, "glm_client: --group %s: not an address\n", o.group.c_str());
			return -1;
		}
		family = group->ai_family;
	}
	unsigned ifindex = o.iface.empty() ? 0 : if_nametoindex(o.iface.c_str());
	if (!o.iface.empty() && !ifindex) {
		std::fprintf(stderr, "glm_client: --interface %s: no such interface\n", o.iface.c_str());
		freeaddrinfo(group);
		return -1;
	}

	int fd = socket(family, SOCK_DGRAM | SOCK_CLOEXEC, 0);
	int one = 1, ret = fd < 0 ? -1 : 0;

	if (fd >= 0)
		setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)); // share a group's port
	if (ret == 0 && family == AF_INET) {
		sockaddr_in sa{};
		sa.sin_family = AF_INET;
		sa.sin_port = htons(static_cast<uint16_t>(o.port));
		sa.sin_addr.s_addr = htonl(INADDR_ANY);
		ret = bind(fd, reinterpret_cast<sockaddr *>(&sa), sizeof(sa));
		if (ret == 0 && group) {
			ip_mreqn mr{};
			mr.imr_multiaddr = reinterpret_cast<sockaddr_in *>(group->ai_addr)->sin_addr;
			mr.imr_ifindex = static_cast<int>(ifindex);
			ret = setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mr, sizeof(mr));
		}
	} else if (ret == 0) {
		sockaddr_in6 sa{};
		sa.sin6_family = AF_INET6;
		sa.sin6_port = htons(static_cast<uint16_t>(o.port));
		sa.sin6_addr = in6addr_any;
		ret = bind(fd, reinterpret_cast<sockaddr *>(&sa), sizeof(sa));
		if (ret == 0) {
			ipv6_mreq mr{};
			mr.ipv6mr_multiaddr = reinterpret_cast<sockaddr_in6 *>(group->ai_addr)->sin6_addr;
			mr.ipv6mr_interface = ifindex;
			ret = setsockopt(fd, IPPROTO_IPV6, IPV6_JOIN_GROUP, &mr, sizeof(mr));
		}
	}
	if (ret < 0) {
		std::fprintf(stderr, "glm_client: UDP port %d%s%s: %s\n", o.port, group ? " group " : "",
			     o.group.c_str(), std::strerror(errno));
		if (fd >= 0)
			close(fd);
		fd = -1;
	}
	freeaddrinfo(group);
	return fd;
}

/* ---- poses and bones ------------------------------------------------------------- */

glm::vec3 to_vec3(const float v[3])
{
	return glm::vec3(v[0], v[1], v[2]);
}

/*
 * The wire stores quaternions w, x, y, z. glm::quat's constructor takes
 * (w, x, y, z) too, but its memory order is x, y, z, w: never memcpy one
 * into the other.
 */
glm::quat to_quat(const float q[4])
{
	return glm::normalize(glm::quat(q[0], q[1], q[2], q[3]));
}

/* a published pose as a 4x4 matrix: translate, then rotate (body to world) */
glm::mat4 to_mat4(const wire_pose &p)
{
	return glm::translate(glm::mat4(1.0f), to_vec3(p.p)) * glm::mat4_cast(to_quat(p.q));
}

bool finite(const wire_pose &p)
{
	for (float v : p.p)
		if (!std::isfinite(v))
			return false;
	for (float v : p.q)
		if (!std::isfinite(v))
			return false;
	return true;
}

/*
 * One arm, from the chest out. Joint i of the arm (DESCRIBE: axis a_i,
 * translation t_i, segment s_i) rotates by its angle q_i about a_i and then
 * moves by t_i in the rotated frame:
 *
 *   K_0 = chest pose,  K_i = K_{i-1} * Rot(a_i, q_i) * Trans(t_i).
 *
 * The bone of segment s is the frame right after the rotation of the last
 * joint that names s: shoulder after the humeral rotation, elbow after the
 * elbow flexion, wrist after the wrist deviation. The hand is K_8, the end
 * of the chain. first is the arm's first joint index (1: right, 9: left).
 */
void arm_bones(const wire_describe &desc, const wire_frame &frame, int first, const glm::mat4 &chest,
	       glm::mat4 bone[WIRE_SEGMENTS], bool have[WIRE_SEGMENTS])
{
	glm::mat4 k = chest;

	for (int i = first; i < first + 8; i++) {
		const wire_joint_desc &j = desc.joint[i];
		glm::mat4 rotated = glm::rotate(k, frame.joint[i], to_vec3(j.axis)); // k * Rot(a, q)

		if (j.segment < WIRE_SEGMENTS) {
			bone[j.segment] = rotated;
			have[j.segment] = true;
		}
		k = glm::translate(rotated, to_vec3(j.trans)); // rotated * Trans(t)
	}
	int hand = first == 1 ? WIRE_SEG_R_HAND : WIRE_SEG_L_HAND;
	bone[hand] = k;
	have[hand] = true;
}

/* ---- the comparison ---------------------------------------------------------------- */

struct error {
	double pos = 0, rot = 0;
};

/* position distance and the angle of the rotation between the two frames */
error compare(const glm::mat4 &mine, const wire_pose &published)
{
	error e;
	glm::quat a = glm::quat_cast(glm::mat3(mine));
	glm::quat d = glm::inverse(a) * to_quat(published.q);

	e.pos = glm::distance(glm::vec3(mine[3]), to_vec3(published.p)); // column 3: the translation
	/* 2 atan2(|v|, |w|) stays accurate for tiny angles, unlike 2 acos(w) */
	e.rot = 2.0 * std::atan2(glm::length(glm::vec3(d.x, d.y, d.z)), std::fabs(d.w));
	if (!finite(published))
		e.pos = e.rot = INFINITY; // finite angles but no pose: a disagreement
	return e;
}

struct worst {
	double err = -1;
	uint32_t seq = 0;
	uint16_t avatar = 0;
	int segment = 0;
};

struct summary {
	long frames = 0, arms_skipped = 0, waiting = 0;
	worst pos, rot;
	bool failed = false;
};

void note(worst &w, double err, const wire_frame &f, int segment)
{
	if (err > w.err || (std::isnan(err) && !std::isnan(w.err))) {
		w.err = err;
		w.seq = f.h.seq;
		w.avatar = f.h.avatar_id;
		w.segment = segment;
	}
}

/* checks one frame; prints a line unless quiet */
void check_frame(const options &o, const wire_describe &desc, const wire_frame &f, summary &sum)
{
	const wire_pose &chest_pose = f.segment[WIRE_SEG_CHEST];
	glm::mat4 bone[WIRE_SEGMENTS];
	bool have[WIRE_SEGMENTS] = {};
	worst fpos, frot;

	if (!finite(chest_pose)) {
		sum.arms_skipped += 2;
		return;
	}
	glm::mat4 chest = to_mat4(chest_pose);

	/*
	 * The chest itself: turned by chest_yaw about the DESCRIBE's axis (world
	 * z), and pitched forward when the person bows (no joint carries the
	 * bow in version 1: it is the rest of the segment's rotation, its swing
	 * away from the axis). So the rebuilt chest is the published one with
	 * its twist about the axis replaced by chest_yaw: what is compared is
	 * the heading. Its position comes from the head sensor, not from a joint.
	 */
	if (std::isfinite(f.joint[0])) {
		glm::vec3 axis = glm::normalize(to_vec3(desc.joint[0].axis));
		glm::quat yaw = glm::angleAxis(f.joint[0], axis);
		glm::quat q = glm::quat_cast(glm::mat3(chest));
		glm::vec3 along = glm::dot(glm::vec3(q.x, q.y, q.z), axis) * axis;
		glm::quat twist(q.w, along.x, along.y, along.z);

		if (glm::length(twist) > 1e-6f)
			twist = glm::normalize(twist);
		else
			twist = glm::quat(1.0f, 0.0f, 0.0f, 0.0f); /* upside down: no heading */
		glm::quat swing = q * glm::inverse(twist);

		bone[WIRE_SEG_CHEST] =
			glm::translate(glm::mat4(1.0f), to_vec3(chest_pose.p)) * glm::mat4_cast(swing * yaw);
		have[WIRE_SEG_CHEST] = true;
	}
	for (int first : { 1, 9 }) {
		bool ok = true;

		for (int i = first; i < first + 8; i++)
			ok = ok && std::isfinite(f.joint[i]);
		if (!ok) {
			sum.arms_skipped++;
			continue;
		}
		arm_bones(desc, f, first, chest, bone, have);
	}
	/* the head is not derived from joint angles in version 1: nothing to rebuild */
	for (int s = 0; s < WIRE_SEGMENTS; s++) {
		if (!have[s])
			continue;
		error e = compare(bone[s], f.segment[s]);

		note(fpos, e.pos, f, s);
		note(frot, e.rot, f, s);
	}
	sum.frames++;
	bool bad = false;
	if (fpos.err >= 0) { // something finite was compared
		note(sum.pos, fpos.err, f, fpos.segment);
		note(sum.rot, frot.err, f, frot.segment);
		bad = !(fpos.err <= o.tol_pos) || !(frot.err <= o.tol_rot);
	}
	sum.failed = sum.failed || bad;
	if (!o.quiet)
		std::printf("avatar %u seq %u: position %.2e m (%s), rotation %.2e rad (%s)%s\n", f.h.avatar_id,
			    f.h.seq, fpos.err < 0 ? 0.0 : fpos.err, wire_segment_names[fpos.segment],
			    frot.err < 0 ? 0.0 : frot.err, wire_segment_names[frot.segment], bad ? "  DISAGREE" : "");
}

/* ---- the loop ------------------------------------------------------------------------ */

volatile std::sig_atomic_t stop = 0;

void on_signal(int)
{
	stop = 1;
}

/*
 * A skeleton belongs to one daemon run (source_id) and one revision
 * (describe_rev): a FRAME naming another pair waits for the next DESCRIBE.
 */
struct skeleton {
	uint32_t source_id, rev;
	wire_describe desc;
};

} // namespace

int main(int argc, char **argv)
{
	options o;
	if (!parse(argc, argv, o))
		return 2;
	int fd = open_udp(o);
	if (fd < 0)
		return 1;

	struct sigaction sa {
	};
	sa.sa_handler = on_signal; // no SA_RESTART: poll() returns EINTR
	sigaction(SIGINT, &sa, nullptr);
	sigaction(SIGTERM, &sa, nullptr);

	std::map<uint16_t, skeleton> skeletons;
	summary sum;
	int status = 0;
	static uint8_t buf[65536];
	static wire_frame frame;

	while (!stop && (o.count == 0 || sum.frames < o.count)) {
		pollfd p = { fd, POLLIN, 0 };
		int n = poll(&p, 1, o.timeout > 0 ? static_cast<int>(o.timeout * 1000) : -1);

		if (n < 0 && errno == EINTR)
			continue;
		if (n == 0) {
			std::fprintf(stderr, "glm_client: nothing received for %g s\n", o.timeout);
			status = 1;
			break;
		}
		ssize_t len = recv(fd, buf, sizeof(buf), 0);
		if (len < 0)
			continue;

		wire_header h;
		int type = wire_peek(buf, static_cast<size_t>(len), &h);
		if (type < 0 || (o.avatar >= 0 && h.avatar_id != o.avatar))
			continue;
		if (type == WIRE_DESCRIBE) {
			skeleton s;
			if (wire_decode_describe(buf, static_cast<size_t>(len), &s.desc) == 0) {
				s.source_id = h.source_id;
				s.rev = h.describe_rev;
				skeletons[h.avatar_id] = s;
			}
		} else if (type == WIRE_FRAME && wire_decode_frame(buf, static_cast<size_t>(len), &frame) == 0) {
			auto it = skeletons.find(h.avatar_id);
			if (it == skeletons.end() || it->second.source_id != h.source_id ||
			    it->second.rev != h.describe_rev) {
				sum.waiting++; // DESCRIBE comes at least once a second
				continue;
			}
			check_frame(o, it->second.desc, frame, sum);
		}
	}
	close(fd);

	std::printf("glm_client: %ld frames checked, %ld arms skipped (non-finite angles), %ld frames before a "
		    "matching DESCRIBE\n",
		    sum.frames, sum.arms_skipped, sum.waiting);
	if (sum.pos.err >= 0)
		std::printf("glm_client: worst position error %.3e m (avatar %u seq %u %s), worst rotation error "
			    "%.3e rad (avatar %u seq %u %s); tolerances %g m, %g rad\n",
			    sum.pos.err, sum.pos.avatar, sum.pos.seq, wire_segment_names[sum.pos.segment], sum.rot.err,
			    sum.rot.avatar, sum.rot.seq, wire_segment_names[sum.rot.segment], o.tol_pos, o.tol_rot);
	if (sum.failed) {
		std::printf("glm_client: DISAGREE: rebuilt bones differ from the published segments\n");
		status = 1;
	}
	if (o.count && sum.frames < o.count)
		status = 1;
	return status;
}
