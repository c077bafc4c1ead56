// SPDX-License-Identifier: MIT
/*
 * cancodec.c - see cancodec.h.
 */
#include "wire/cancodec.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void put_i16(uint8_t *b, int16_t v)
{
	uint16_t u = (uint16_t)v;

	b[0] = (uint8_t)u;
	b[1] = (uint8_t)(u >> 8);
}

static int16_t get_i16(const uint8_t *b)
{
	return (int16_t)(uint16_t)(b[0] | b[1] << 8);
}

static int16_t saturate(double v)
{
	/* INT16_MIN is kept for "unknown" */
	if (v >= 32767)
		return 32767;
	if (v <= -32767)
		return -32767;
	return (int16_t)lround(v);
}

int16_t cancodec_centideg(double rad)
{
	if (!isfinite(rad))
		return isnan(rad) ? CANCODEC_UNKNOWN : rad > 0 ? 32767 : -32767;
	return saturate(rad * (18000.0 / M_PI));
}

double cancodec_rad(int16_t centideg)
{
	return centideg == CANCODEC_UNKNOWN ? NAN : centideg * (M_PI / 18000.0);
}

static canid_t id_bits(canid_t id)
{
	return id & (id & CAN_EFF_FLAG ? CAN_EFF_MASK : CAN_SFF_MASK);
}

canid_t cancodec_id(canid_t id0, int frame)
{
	return (id0 & CAN_EFF_FLAG) | (id_bits(id0) + (canid_t)frame);
}

void cancodec_encode_avatar(const struct cancodec_avatar *a, canid_t id0, struct can_frame f[CANCODEC_FRAMES])
{
	memset(f, 0, sizeof(*f) * CANCODEC_FRAMES);
	for (int i = 0; i < CANCODEC_FRAMES; i++) {
		f[i].can_id = cancodec_id(id0, i);
		f[i].len = 8;
	}
	f[0].data[0] = a->counter;
	f[0].data[1] = a->flags;
	f[0].data[2] = a->sensors;
	f[0].data[3] = a->ik;
	put_i16(&f[0].data[4], a->joint[0]);
	f[0].data[6] = (uint8_t)a->age_ms;
	f[0].data[7] = (uint8_t)(a->age_ms >> 8);
	/* joints 1..16 four to a frame: right j1..j4, j5..j8, left j1..j4, j5..j8 */
	for (int j = 1; j < CANCODEC_JOINTS; j++)
		put_i16(&f[1 + (j - 1) / 4].data[2 * ((j - 1) % 4)], a->joint[j]);
}

int cancodec_decode_avatar(const struct can_frame *f, canid_t id0, struct cancodec_avatar *a)
{
	canid_t id = f->can_id;
	int k;

	if ((id & (CAN_RTR_FLAG | CAN_ERR_FLAG)) || (id & CAN_EFF_FLAG) != (id0 & CAN_EFF_FLAG) ||
	    id_bits(id) < id_bits(id0) || id_bits(id) >= id_bits(id0) + CANCODEC_FRAMES)
		return -ENOENT;
	k = (int)(id_bits(id) - id_bits(id0));
	if (f->len != 8)
		return -EBADMSG;
	if (k == CANCODEC_STATUS) {
		a->counter = f->data[0];
		a->flags = f->data[1];
		a->sensors = f->data[2];
		a->ik = f->data[3];
		a->joint[0] = get_i16(&f->data[4]);
		a->age_ms = (uint16_t)(f->data[6] | f->data[7] << 8);
		return k;
	}
	for (int i = 0; i < 4; i++)
		a->joint[1 + 4 * (k - 1) + i] = get_i16(&f->data[2 * i]);
	return k;
}

/* ---- sensors ------------------------------------------------------------------------ */

/* the sensor whose frame of base `base` has identifier id, or -1 */
static int sensor_of(const struct cancodec_sensor_map *m, canid_t base, canid_t id)
{
	if (base == CANCODEC_NO_ID || (id & CAN_EFF_FLAG) != (base & CAN_EFF_FLAG))
		return -1;
	if (id_bits(id) < id_bits(base) || id_bits(id) >= id_bits(base) + (canid_t)m->n)
		return -1;
	return (int)(id_bits(id) - id_bits(base));
}

int cancodec_decode_sensor(const struct cancodec_sensor_map *m, const struct can_frame *f,
			   struct cancodec_sensor_value *out)
{
	int k;

	if (f->can_id & (CAN_RTR_FLAG | CAN_ERR_FLAG))
		return -ENOENT;
	if ((k = sensor_of(m, m->ori_id, f->can_id)) >= 0) {
		double c[4], n = 0;

		if (f->len != 8)
			return -EBADMSG;
		for (int i = 0; i < 4; i++) {
			c[i] = get_i16(&f->data[2 * i]) / m->quat_scale;
			n += c[i] * c[i];
		}
		n = sqrt(n);
		if (!(n > 0.8 && n < 1.2))
			return -EDOM;
		for (int i = 0; i < 4; i++)
			out->v[i] = (m->xyzw ? c[(i + 3) % 4] : c[i]) / n;
		out->sensor = k;
		out->kind = CANCODEC_ORIENTATION;
		return 0;
	}
	if ((k = sensor_of(m, m->pos_id, f->can_id)) >= 0) {
		if (f->len != 6 && f->len != 8)
			return -EBADMSG;
		for (int i = 0; i < 3; i++)
			out->v[i] = get_i16(&f->data[2 * i]) * m->pos_scale;
		out->v[3] = 0;
		out->sensor = k;
		out->kind = CANCODEC_POSITION;
		return 0;
	}
	return -ENOENT;
}

void cancodec_encode_orientation(const struct cancodec_sensor_map *m, int sensor, const double q[4],
				 struct can_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->can_id = cancodec_id(m->ori_id, sensor);
	f->len = 8;
	for (int i = 0; i < 4; i++)
		put_i16(&f->data[2 * i], saturate(q[m->xyzw ? (i + 1) % 4 : i] * m->quat_scale));
}

void cancodec_encode_position(const struct cancodec_sensor_map *m, int sensor, const double p[3], struct can_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->can_id = cancodec_id(m->pos_id, sensor);
	f->len = 6;
	for (int i = 0; i < 3; i++)
		put_i16(&f->data[2 * i], saturate(p[i] / m->pos_scale));
}

/* ---- candump -L --------------------------------------------------------------------- */

int cancodec_format_line(const struct can_frame *f, uint64_t t_us, const char *ifname, char *buf, size_t len)
{
	int n = snprintf(buf, len, "(%010llu.%06llu) %s ", (unsigned long long)(t_us / 1000000),
			 (unsigned long long)(t_us % 1000000), ifname);

	if (n < 0 || (size_t)n >= len)
		return -ENOSPC;
	if (f->can_id & CAN_EFF_FLAG)
		n += snprintf(buf + n, len - (size_t)n, "%08X#", f->can_id & CAN_EFF_MASK);
	else
		n += snprintf(buf + n, len - (size_t)n, "%03X#", f->can_id & CAN_SFF_MASK);
	if ((size_t)n >= len)
		return -ENOSPC;
	if (f->can_id & CAN_RTR_FLAG) {
		n += snprintf(buf + n, len - (size_t)n, "R");
	} else {
		for (int i = 0; i < f->len && i < CAN_MAX_DLEN; i++)
			n += snprintf(buf + n, len - (size_t)n, "%02X", f->data[i]);
	}
	return (size_t)n >= len ? -ENOSPC : n;
}

static int hexval(int c)
{
	if (c >= '0' && c <= '9')
		return c - '0';
	c = tolower(c);
	return c >= 'a' && c <= 'f' ? c - 'a' + 10 : -1;
}

int cancodec_parse_line(const char *line, struct can_frame *f, uint64_t *t_us, char *ifname, size_t iflen)
{
	const char *p = line, *q;
	unsigned long long sec = 0, usec = 0;
	size_t ndig = 0;
	canid_t id = 0;

	memset(f, 0, sizeof(*f));
	if (*p++ != '(')
		return -EINVAL;
	for (; isdigit((unsigned char)*p); p++)
		sec = sec * 10 + (unsigned)(*p - '0');
	if (*p++ != '.')
		return -EINVAL;
	for (; isdigit((unsigned char)*p) && ndig < 6; p++, ndig++)
		usec = usec * 10 + (unsigned)(*p - '0');
	if (ndig != 6 || *p++ != ')' || *p++ != ' ')
		return -EINVAL;
	q = strchr(p, ' ');
	if (!q || q == p)
		return -EINVAL;
	if (ifname) {
		if ((size_t)(q - p) >= iflen)
			return -EINVAL;
		memcpy(ifname, p, (size_t)(q - p));
		ifname[q - p] = '\0';
	}
	p = q + 1;
	for (ndig = 0; hexval((unsigned char)*p) >= 0; p++, ndig++)
		id = id << 4 | (canid_t)hexval((unsigned char)*p);
	if (*p++ != '#')
		return -EINVAL;
	if (ndig == 3 && id <= CAN_SFF_MASK)
		f->can_id = id;
	else if (ndig == 8 && id <= CAN_EFF_MASK)
		f->can_id = id | CAN_EFF_FLAG;
	else
		return -EINVAL;
	if (*p == 'R') {
		f->can_id |= CAN_RTR_FLAG;
		p++;
	} else {
		while (hexval((unsigned char)p[0]) >= 0 && hexval((unsigned char)p[1]) >= 0) {
			if (f->len == CAN_MAX_DLEN)
				return -EINVAL;
			f->data[f->len++] = (uint8_t)(hexval((unsigned char)p[0]) << 4 | hexval((unsigned char)p[1]));
			p += 2;
		}
	}
	while (*p == '\r' || *p == '\n')
		p++;
	if (*p)
		return -EINVAL;
	if (t_us)
		*t_us = sec * 1000000ull + usec;
	return 0;
}
