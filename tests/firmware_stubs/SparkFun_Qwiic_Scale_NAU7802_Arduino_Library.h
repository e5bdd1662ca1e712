/* A stub of SparkFun's NAU7802 library's interface (begin, available, getReading) over the
 * simulator's mailbox. */
#ifndef NAU7802_STUB_H
#define NAU7802_STUB_H
#include "Arduino.h"
#include "Wire.h"

class NAU7802 {
public:
    bool begin() { return true; }
    bool available() { return true; }
    int32_t getReading() { return (int32_t)stub_next_code(); }
};
#endif
