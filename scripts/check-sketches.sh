#!/usr/bin/env bash
# Compiles the Arduino sketches in hardware/ (regulator, pwm_valve) for an Uno and a Mega
# 2560 with avr-gcc and the Arduino AVR core from Debian (arduino-mk, arduino-core-avr,
# gcc-avr, avr-libc; installed when missing, as root), and prints their flash and RAM use.
# Not part of scripts/test.sh (the AVR toolchain is ~150 MB). Debian 12's core 1.8.7 does
# not build with its avr-libc 2.0 (WString.cpp uses DECIMAL_DIG, which that libc's
# float.h lacks): it is defined to 9, float's value, for the core.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
if [ ! -f /usr/share/arduino/Arduino.mk ] || ! command -v avr-gcc > /dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q arduino-mk arduino-core-avr gcc-avr avr-libc > /dev/null
fi
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for sketch in regulator pwm_valve; do
    for board in uno mega; do
        dir="$work/$sketch-$board"
        mkdir -p "$dir"
        cp "$root/hardware/$sketch/$sketch.ino" "$dir/"
        {
            echo "CPPFLAGS += -DDECIMAL_DIG=9"
            echo "BOARD_TAG = $board"
            [ "$board" = mega ] && echo "BOARD_SUB = atmega2560"
            echo "ARDUINO_DIR = /usr/share/arduino"
            echo "include /usr/share/arduino/Arduino.mk"
        } > "$dir/Makefile"
        if ! (cd "$dir" && make -s > build.log 2>&1); then
            cat "$dir/build.log" >&2
            echo "hardware/$sketch/$sketch.ino: does not compile for $board" >&2
            exit 1
        fi
        sizes="$(grep -E "Program:|Data:" "$dir/build.log" | tr -s ' ' | tr '\n' ' ')"
        echo "hardware/$sketch/$sketch.ino for $board: $sizes"
    done
done
