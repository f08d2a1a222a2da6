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
# The keys, generated from /dev/urandom on first use by
# tools/setup/device-key (git-ignored, owner-only; a warning when others may
# read one): KEY_FILE (default keys/device.key), the device's, which only
# `make flash` uses; SIM_KEY_FILE (keys/sim.key), the simulations', which
# `make sim`, `make hil`, `make pil` and `make replay` use, so that no
# simulation's bus.log holds a command a board accepts. Board images are
# built without a key: install_key writes one into a private copy
# (tools/setup/install-key); the host library and mstc-fw load a key at
# start, and the tools read the file they are given (mstc --key-file).
# tests/data/test.key is a published test key: the committed logs and the
# tests use it; never flash it.
#
#   make key      create KEY_FILE and SIM_KEY_FILE if they do not exist

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
SIM_KEY_FILE ?= keys/sim.key
TEST_KEY_FILE := tests/data/test.key
KEY_BIN := build/key/device.bin
SIM_KEY_BIN := build/key/sim.bin

$(KEY_FILE) $(SIM_KEY_FILE):
	@tools/setup/device-key $@
$(KEY_BIN): $(KEY_FILE) tools/setup/device-key
	@tools/setup/device-key $< --bin $@
$(SIM_KEY_BIN): $(SIM_KEY_FILE) tools/setup/device-key
	@tools/setup/device-key $< --bin $@

# install_key,IMAGE.elf,KEY.bin,OUT.elf: the recipe of a private copy of a
# board image with the key in its .auth_key section.
install_key = OBJCOPY=$(CROSS_COMPILE)objcopy tools/setup/install-key $(1) $(2) $(3)

.PHONY: key
key: $(KEY_FILE) $(SIM_KEY_FILE)  ## create the device and simulation keys keys/{device,sim}.key (git-ignored) if there are none
