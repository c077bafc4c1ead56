/* SPDX-License-Identifier: MIT */
/*
 * modbus_server.h - the options of modbus_server.c's configuration sections (its keys' values).
 */
#ifndef AGW_MODBUS_SERVER_H
#define AGW_MODBUS_SERVER_H

#include "config/config.h"

struct modbus_out_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	int max_clients;
	int clients_per_address; /* 0: no limit but max_clients */
	int reg_base;		 /* input register of the first avatar's block */
	int reg_stride;		 /* registers from one avatar's block to the next */
	int word_order;		 /* enum cfg_word_order */
	int writable_regs;	 /* holding registers clients may write, 0: writes refused */
	double idle_timeout;	 /* s, 0: never */
};

#endif /* AGW_MODBUS_SERVER_H */
