// bendscope PWM solenoid valve: an Arduino (Mega 2560 or Uno) pulsing a 3/2 solenoid
// valve (e.g. SMC V114: energised, supply -> actuator; released, actuator -> exhaust)
// through a logic-level MOSFET at 20 Hz, and closing the loop on a pressure sensor, as
// in the published protocol (an Arduino Mega pulsing a solenoid valve at 20 Hz).
//
// Host line protocol (115200 baud, 8N1, lines end in \n; \r is ignored), the same as
// hardware/regulator/regulator.ino, so bendscope drives either with [regulator]:
//   SET <kPa>      ->  OK <kPa>          closed loop to this set point (0 .. MAX_KPA);
//                                        SET 0 releases the valve (vents)
//   GET            ->  P <kPa>           measured pressure: the mean of the sensor over the
//                                        last PWM period (the valve's ripple averaged out)
//   DUTY <percent> ->  OK DUTY <percent> open loop: this duty (0 .. 100 %), no control
//                                        (until the next SET)
//   anything else  ->  ERR <text>        out of range, sensor fault, unknown command
// At power-up (and when the host opens the port, which resets the board) the valve is
// released (0 % duty). If the host sends nothing for HOST_TIMEOUT_MS, the valve is
// released: a host that crashed does not leave the actuator under pressure (bendscope
// talks at least once a second).
//
// Control (once per PWM period, T = 50 ms), with e = set point - measured pressure (kPa):
//   duty % = FF + KP * e + I,   FF = 100 * set point / SUPPLY_KPA (the duty whose mean
//   flow balances the exhaust at the set point when fill and exhaust are alike),
//   I += KI * e * T, except while the duty is pinned at 0 or 100 % and e pushes it
//   further (no wind-up), I within -100 .. 100 %, duty within 0 .. 100 %.
// KP = 1.5 %/kPa and KI = 3 %/(kPa s) suit a small actuator (a few cm3) on a V114 at
// 200 kPa supply: the averaged pressure follows the duty with a time constant of about
// 0.3 s; bendscope's tests (tests/acquire.rs) simulate this plant with this controller
// and reach each set point within 0.25 kPa after stabilize_s = 3 s (the integral settles
// with a time constant of about 0.7 s: give stabilize_s >= 3). A larger volume: raise KP
// and KI in proportion to it; an oscillating pressure: halve KP.
//
// Wiring (see README, section acquire):
//   pin 11 (Mega) or pin 9 (Uno): Timer 1 output OC1A, 20 Hz PWM -> 220 Ohm -> gate of a
//       logic-level N-MOSFET (IRLZ44N), 10 kOhm gate to GND; drain -> valve coil -> +12 V
//       (or the valve's rated voltage), a flyback diode (1N4007) across the coil
//       (cathode to +12 V); source -> GND
//   A0 <- pressure sensor output (e.g. MPX5700DP: 0.2 V at 0 kPa .. 4.7 V at 700 kPa)
//   GND common to the Arduino, the MOSFET source, the 12 V supply and the sensor.

const long BAUD = 115200;
#if defined(__AVR_ATmega2560__)
const int VALVE_PIN = 11;  // OC1A on the Mega
#else
const int VALVE_PIN = 9;   // OC1A on the Uno
#endif
const int SENSOR_PIN = A0;

// PWM: Timer 1, fast PWM with TOP = ICR1, prescaler 256: 16 MHz / 256 / (TOP + 1) = 20 Hz.
const unsigned int PWM_TOP = 3124;
const unsigned long PERIOD_MS = 50;

// Supply pressure on the valve's inlet, kPa (feed-forward).
const float SUPPLY_KPA = 200.0;
// Highest set point accepted, kPa (below the supply).
const float MAX_KPA = 150.0;
// Controller gains: %/kPa and %/(kPa s).
const float KP = 1.5;
const float KI = 3.0;

// The sensor: SENSOR_V0 volts at 0 kPa, SENSOR_KPA_PER_V kPa per volt above it.
const float SENSOR_V0 = 0.2;
const float SENSOR_KPA_PER_V = 700.0 / 4.5;
// A sensor reading below this voltage means a broken wire.
const float SENSOR_MIN_V = 0.05;
const float ADC_REF_V = 5.0;
// One sensor reading every SAMPLE_MS: PERIOD_MS / SAMPLE_MS readings per period.
const unsigned long SAMPLE_MS = 2;
const unsigned long HOST_TIMEOUT_MS = 120000UL;

float setPointKpa = 0.0;
bool openLoop = false;
float dutyPct = 0.0;
float integralPct = 0.0;
// Mean pressure of the last full period, kPa; negative: sensor fault.
float periodMeanKpa = 0.0;
long sampleSum = 0;
int sampleCount = 0;
unsigned long lastSampleMs = 0;
unsigned long periodStartMs = 0;
unsigned long lastCommandMs = 0;
char line[48];
byte lineLen = 0;

void writeDuty(float pct) {
  dutyPct = constrain(pct, 0.0, 100.0);
  OCR1A = (unsigned int)(dutyPct / 100.0 * PWM_TOP + 0.5);
}

void vent() {
  setPointKpa = 0.0;
  openLoop = false;
  integralPct = 0.0;
  writeDuty(0.0);
}

float kpaFromCounts(float counts) {
  float volts = ADC_REF_V * counts / 1023.0;
  if (volts < SENSOR_MIN_V) return -1.0;
  float kpa = (volts - SENSOR_V0) * SENSOR_KPA_PER_V;
  return kpa < 0.0 ? 0.0 : kpa;
}

// Once per period: the mean pressure, then the controller's new duty.
void endOfPeriod() {
  periodMeanKpa = sampleCount > 0 ? kpaFromCounts(sampleSum / (float)sampleCount) : -1.0;
  sampleSum = 0;
  sampleCount = 0;
  if (openLoop) return;
  if (setPointKpa <= 0.0 || periodMeanKpa < 0.0) {
    integralPct = 0.0;
    writeDuty(0.0);  // vented, or no sensor: never fill blind
    return;
  }
  float e = setPointKpa - periodMeanKpa;
  float ffPct = 100.0 * setPointKpa / SUPPLY_KPA;
  float raw = ffPct + KP * e + integralPct;
  if ((raw < 100.0 || e < 0.0) && (raw > 0.0 || e > 0.0)) {
    integralPct = constrain(integralPct + KI * e * (PERIOD_MS / 1000.0), -100.0, 100.0);
  }
  writeDuty(ffPct + KP * e + integralPct);
}

void handle(char *cmd) {
  if (strncmp(cmd, "SET ", 4) == 0) {
    char *end;
    float kpa = strtod(cmd + 4, &end);
    if (end == cmd + 4) {
      Serial.println(F("ERR SET needs a number in kPa"));
    } else if (kpa < 0.0 || kpa > MAX_KPA) {
      Serial.print(F("ERR out of range 0.."));
      Serial.print(MAX_KPA, 2);
      Serial.println(F(" kPa"));
    } else {
      if (kpa == 0.0) {
        vent();
      } else {
        if (openLoop) integralPct = 0.0;
        openLoop = false;
        setPointKpa = kpa;
      }
      Serial.print(F("OK "));
      Serial.println(kpa, 2);
    }
  } else if (strncmp(cmd, "DUTY ", 5) == 0) {
    char *end;
    float pct = strtod(cmd + 5, &end);
    if (end == cmd + 5 || pct < 0.0 || pct > 100.0) {
      Serial.println(F("ERR DUTY needs a percentage 0..100"));
    } else {
      openLoop = true;
      setPointKpa = 0.0;
      integralPct = 0.0;
      writeDuty(pct);
      Serial.print(F("OK DUTY "));
      Serial.println(pct, 1);
    }
  } else if (strcmp(cmd, "GET") == 0) {
    if (periodMeanKpa < 0.0) {
      Serial.println(F("ERR sensor fault: no signal on A0"));
    } else {
      Serial.print(F("P "));
      Serial.println(periodMeanKpa, 3);
    }
  } else {
    Serial.println(F("ERR unknown command (SET <kPa>, GET or DUTY <percent>)"));
  }
}

void setup() {
  pinMode(VALVE_PIN, OUTPUT);
  // Timer 1: fast PWM, TOP = ICR1 (mode 14), non-inverting on OC1A, prescaler 256.
  TCCR1A = _BV(COM1A1) | _BV(WGM11);
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS12);
  ICR1 = PWM_TOP;
  vent();
  Serial.begin(BAUD);
  lastCommandMs = millis();
  periodStartMs = millis();
}

void loop() {
  unsigned long now = millis();
  if (now - lastSampleMs >= SAMPLE_MS) {
    lastSampleMs = now;
    sampleSum += analogRead(SENSOR_PIN);
    sampleCount++;
  }
  if (now - periodStartMs >= PERIOD_MS) {
    periodStartMs += PERIOD_MS;
    endOfPeriod();
  }
  while (Serial.available() > 0) {
    char c = Serial.read();
    if (c == '\r') continue;
    if (c == '\n') {
      line[lineLen] = '\0';
      if (lineLen > 0) handle(line);
      lineLen = 0;
      lastCommandMs = millis();
    } else if (lineLen < sizeof(line) - 1) {
      line[lineLen++] = c;
    }
  }
  if ((setPointKpa > 0.0 || dutyPct > 0.0) && millis() - lastCommandMs > HOST_TIMEOUT_MS) {
    vent();  // the host is gone
  }
}
