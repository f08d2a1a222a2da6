/* SPDX-License-Identifier: MIT */
/*
 * Mbed TLS configuration of the firmware: the AES block cipher and nothing
 * else. It takes the place of Mbed TLS's own mbedtls/config.h, being found
 * first on the include path (AUTH_CFLAGS in mk/auth.mk): a header rather
 * than -DMBEDTLS_CONFIG_FILE="...", whose quotes every command line that
 * carries the flags would have to keep. Tables in flash (ROM_TABLES), and
 * one table per direction instead of four (FEWER_TABLES): about 1.3 KB of
 * flash for encryption, no RAM, against 8 KB of RAM for tables built at
 * start-up. No assembly and no hardware accelerator: the same C on the host
 * and on Cortex-M.
 */
#ifndef MBEDTLS_CONFIG_H
#define MBEDTLS_CONFIG_H

/** @brief This configuration, not Mbed TLS's default, is in force (auth.c checks). */
#define MSTC_MBEDTLS_CONFIG 1

#define MBEDTLS_AES_C
#define MBEDTLS_AES_ROM_TABLES
#define MBEDTLS_AES_FEWER_TABLES

#include "mbedtls/check_config.h"

#endif /* MBEDTLS_CONFIG_H */
