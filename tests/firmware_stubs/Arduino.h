/* A stub of the Arduino core for compiling sketches for the ATmega328P with avr-g++ and running
 * them on simavr (tests/test_firmware_library.py): no core is downloaded. The converter stubs
 * take their codes from the simulator's mailbox (digital/targets/simavr_run.c's protocol) and
 * Serial.println(float) hands the corrected value back; the rest does nothing. */
#ifndef ARDUINO_STUB_H
#define ARDUINO_STUB_H
#include <stdint.h>
#include <math.h>
#include <avr/io.h>

#define A0 14

/* The next code from the simulator; ends the run when there is none. */
long stub_next_code(void);
void stub_output(float value);

class SerialStub {
public:
    void begin(long) {}
    void print(long) {}
    void print(char) {}
    void print(const char *) {}
    void println(float value) { stub_output(value); }
    void println(const char *) {}
};

extern SerialStub Serial;

inline int analogRead(int) { return 512; }
inline void delay(unsigned long) {}
void setup();
void loop();
#endif
