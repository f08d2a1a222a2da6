# SPDX-License-Identifier: MIT
# Authenticated commands (firmware/auth, docs/safety.md "Threat model"): the
# AES block cipher of Mbed TLS, and the device key.
#
# Mbed TLS 2.28 (an LTS branch) comes from its Debian source package,
# checked against tools/setup/sources.lock, into deps/mbedtls (git-ignored),
# like libfixmath; only aes.c and platform_util.c (mbedtls_platform_zeroize,
# which wipes the key schedule) are compiled, configured by
# firmware/auth/mbedtls-config/mbedtls/config.h. They compile clean under the
# full WARN of every compiler the project uses. Every build that compiles the
# firmware compiles AUTH_SRCS (the Makefile's fw_srcs) with AUTH_CFLAGS, after
# AUTH_DEPS.
#
# The device key: KEY_FILE (default keys/device.key, git-ignored), generated
# from /dev/urandom on first use by tools/setup/device-key. Board images
# compile it in from KEY_HEADER; the host library and mstc-fw load a key at
# start, and the tools read KEY_FILE (mstc --key-file, MSTC_KEY_FILE).
# tests/data/test.key is a published test key: the committed logs and the
# tests use it; never flash it.
#
#   make key      create KEY_FILE if it does not exist (and say so)

MBEDTLS_DIR := deps/mbedtls
AUTH_SRCS := $(MBEDTLS_DIR)/library/aes.c $(MBEDTLS_DIR)/library/platform_util.c
# firmware/auth/mbedtls-config first: its mbedtls/config.h replaces Mbed TLS's.
AUTH_CONFIG_INC := -Ifirmware/auth/mbedtls-config
AUTH_CFLAGS := $(AUTH_CONFIG_INC) -I$(MBEDTLS_DIR)/include
AUTH_DEPS := $(MBEDTLS_DIR)/.sha256

# The sources appear when the source package is fetched (the Makefile's
# deps/%/.sha256 rule).
$(AUTH_SRCS): | $(MBEDTLS_DIR)/.sha256
	@test -f $@ || { echo "error: $@ missing after fetching mbedtls" >&2; exit 1; }

KEY_FILE ?= keys/device.key
TEST_KEY_FILE := tests/data/test.key
KEY_HEADER := build/key/auth_key.h

$(KEY_FILE):
	@tools/setup/device-key $@
$(KEY_HEADER): $(KEY_FILE) tools/setup/device-key
	@tools/setup/device-key $< --header $@

.PHONY: key
key: $(KEY_FILE)  ## create the device key keys/device.key (git-ignored) if there is none
