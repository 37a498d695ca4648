/* mckibben firmware as an Arduino sketch (Arduino Mega 2560; board arduino:avr:mega).
 *
 * `make -C firmware sketch` puts this file and the firmware's C sources into
 * build/sketch/mckibben/ (src/ holds main.c, the controller core and the protocol: the same
 * files `make -C firmware` builds). The program is plain avr-libc: main() and the interrupt
 * handlers are in src/main.c, so this file holds no setup() or loop(), and nothing of the
 * Arduino core (millis, Serial) is linked in. See docs/firmware.md.
 */
