/* A stub of bogde's HX711 library's interface (begin, read) over the simulator's mailbox. */
#ifndef HX711_STUB_H
#define HX711_STUB_H
#include "Arduino.h"

class HX711 {
public:
    void begin(int, int) {}
    long read() { return stub_next_code(); }
};
#endif
