/* SPDX-License-Identifier: MIT */
/*
 * json.h - a JSON string's content, escaped: quotes, backslashes and control
 * characters (the status answers put names, paths and addresses from the
 * configuration, and error texts, into JSON strings).
 */
#ifndef AGW_BASE_JSON_H
#define AGW_BASE_JSON_H

#include <stdio.h>

/* s without its quotes; NULL writes nothing */
static inline void json_escape(FILE *out, const char *s)
{
	for (; s && *s; s++) {
		unsigned char c = (unsigned char)*s;

		if (c == '"' || c == '\\')
			fprintf(out, "\\%c", c);
		else if (c < 0x20 || c == 0x7f)
			fprintf(out, "\\u%04x", c);
		else
			fputc(c, out);
	}
}

/* s with its quotes */
static inline void json_string(FILE *out, const char *s)
{
	fputc('"', out);
	json_escape(out, s);
	fputc('"', out);
}

#endif /* AGW_BASE_JSON_H */
