/* hx711_host.h: the few Arduino functions the sketch uses, on a host, with a simulated HX711
 * whose conversions are read from standard input (one code per line). Not for the target. */
#ifndef HX711_HOST_H
#define HX711_HOST_H
#include <stdint.h>

#define HIGH 1
#define LOW 0
#define INPUT 0
#define OUTPUT 1

void pinMode(int pin, int mode);
void digitalWrite(int pin, int value);
int digitalRead(int pin);
void delayMicroseconds(unsigned int us);
/* Prints "raw<TAB>word" on standard output. */
void host_report(int32_t raw, int32_t corrected_word);
/* Prints "raw<TAB>temperature<TAB>corrected" (the temperature step's output, in counts). */
void host_report_temperature(int32_t raw, float temperature_c, float corrected);
/* The simulated sensor temperature (°C) of the current conversion. */
float host_temperature_c(void);

/* The sketch's entry points. */
void setup(void);
void loop(void);
#endif
