/* SPDX-License-Identifier: MIT */
/*
 * log.h - messages on syslog levels, to stderr; under systemd (JOURNAL_STREAM
 * set) each line carries its level as a "<N>" prefix, which journald reads.
 * Never called from the loop thread: the loop counts, the control thread logs.
 */
#ifndef AGW_LOG_H
#define AGW_LOG_H

#include <syslog.h>

void log_set_level(int syslog_level);
void log_msg(int level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

#define pr_err(...) log_msg(LOG_ERR, __VA_ARGS__)
#define pr_warning(...) log_msg(LOG_WARNING, __VA_ARGS__)
#define pr_notice(...) log_msg(LOG_NOTICE, __VA_ARGS__)
#define pr_info(...) log_msg(LOG_INFO, __VA_ARGS__)
#define pr_debug(...) log_msg(LOG_DEBUG, __VA_ARGS__)

#endif /* AGW_LOG_H */
