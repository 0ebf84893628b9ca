#pragma once

// Register-map profiles of Modbus motor drives (data/devices/<name>.json; the format is described
// in docs/profiles.md). A profile says where each quantity lives, how wide it is, in which word
// order, how a move / homing / stop / alarm reset is triggered and which status bits mean what. The
// codec functions below turn quantities into register words and back, with no I/O: the driver
// (ModbusAxis) and the simulated controller (sim::MotorControllerServer) both use them, so the two
// sides agree register for register.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gonio/base/error.h"

namespace gonio::devices {

/// Order of the two 16-bit registers of a 32-bit value.
enum class WordOrder {
    kHighFirst,  ///< Upper word at the lower address (Oriental Motor, Leadshine).
    kLowFirst,   ///< Lower word at the lower address.
};

/// One value on the wire: a holding register (16 bit) or two consecutive ones (32 bit).
struct RegisterField {
    int address =
        -1;          ///< As the manual documents it (address_base not yet subtracted); -1 = absent.
    int width = 16;  ///< 16 or 32.
    bool is_signed = true;
    std::string section;  ///< Where the drive's manual documents this register ("section").
    bool present() const { return address >= 0; }
    int count() const { return width == 32 ? 2 : 1; }
};

/// What a slot of a command block carries.
enum class Quantity {
    kConstant,  ///< A fixed value (operation type, trigger code, current).
    kTarget,    ///< Target position in steps.
    kSpeed,     ///< Speed in steps/s.
    kAccel,     ///< Acceleration in steps/s^2.
    kDecel,     ///< Deceleration in steps/s^2.
};

/// One field of a command block. Wire value = round(scale * q), or round(scale / q) when `inverse`
/// (drives that take a ramp time, e.g. ms per 1000 rpm). The constant is written as is.
struct BlockSlot {
    Quantity quantity = Quantity::kConstant;
    int width = 32;
    double constant = 0;
    double scale = 1;
    bool inverse = false;
};

/// Consecutive registers written in one request (function 16).
struct CommandBlock {
    int address = -1;  ///< Documented address of the first register; -1 = no block.
    std::vector<BlockSlot> slots;
    std::string section;  ///< Where the drive's manual documents the block ("section").
    bool present() const { return address >= 0; }
    int register_count() const;
};

/// How an action starts once its block (if any) has been written.
enum class TriggerKind {
    kNone,        ///< No separate trigger (or action unsupported when the block is absent too).
    kWriteValue,  ///< Write `value` to `reg` (may lie inside the block: then the block write
                  ///< triggers).
    kPulseBit,    ///< Set `bit` of `reg`, then clear it (edge-triggered input bits).
};

struct Trigger {
    TriggerKind kind = TriggerKind::kNone;
    RegisterField reg;
    std::uint32_t value = 0;
    int bit = -1;
};

struct Action {
    CommandBlock block;
    Trigger trigger;
    bool supported() const { return block.present() || trigger.kind != TriggerKind::kNone; }
};

/// Status bits (all active high; -1 = the drive does not report it).
struct StatusBits {
    RegisterField reg;
    int moving = -1;
    int in_position = -1;
    int homed = -1;
    int alarm = -1;
    int homing = -1;
    int ready = -1;
};

/// Per-profile timing (some drives answer slower than libmodbus' 500 ms default).
struct ProfileTimeouts {
    int response_ms = 500;  ///< Per request.
    int retries = 3;        ///< Further attempts after a failed request.
    int backoff_ms = 20;    ///< First wait between attempts; doubles each time.
    int poll_ms = 5;        ///< Interval between status polls while waiting for a drive flag.
    int stall_ms = 2000;    ///< Position unchanged this long while "moving" = stall.
};

/// Drive alarm codes the simulator raises for its simulated faults.
struct AlarmCodes {
    int overtravel = 1;  ///< A limit switch was hit.
    int overload = 2;    ///< Raised mid-move (injected).
    int deviation = 3;   ///< Excessive position deviation (stall).
};

/// Position compare (optional, fly scans; docs/profiles.md, "Position compare"): a table of
/// counter positions; once armed, the drive sends a pulse on its compare output (wired to the
/// camera's trigger input line) as its encoder passes each entry in turn, counts the pulses, and
/// its touch probe latches each pulse's exposure (the camera's exposure-active line) into a table.
struct PositionCompare {
    RegisterField control;  ///< Write 1: arm (the count and latches reset), 0: disarm.
    RegisterField count;    ///< Entries of the table in use.
    RegisterField fired;    ///< Pulses sent since armed (the drive writes it).
    RegisterField table;  ///< Entry k (steps, as `position`) at table.address + k * table.count().
    /// Latch of pulse k (1-based) at latches.address + 2 (k - 1) * latches.count(): the position at
    /// its exposure's start, then at its end.
    RegisterField latches;
    int entries = 0;  ///< Table size.
    bool present() const { return control.present(); }
};

struct AxisProfile {
    std::string name;
    std::string description;
    std::string source;  ///< The public document the register map was taken from.
    /// Subtracted from documented addresses to get the wire (PDU) address: 0 when the manual lists
    /// PDU addresses, 1 for 1-based register numbers, 40001 for "4xxxx" numbering.
    int address_base = 0;
    WordOrder word_order = WordOrder::kHighFirst;
    double steps_per_degree = 100;
    int direction = 1;  ///< +1 or -1: sign of steps for a positive angle.
    double max_speed_deg_per_s = 90;
    double home_speed_deg_per_s = 30;  ///< Used by the simulator's homing.

    RegisterField position;  ///< Feedback position, steps.
    StatusBits status;
    RegisterField alarm_code;  ///< Present alarm code.
    /// Touch probe (optional, fly scans): the position latched at the rising and at the falling
    /// edge of the camera's exposure-active line, steps (as `position`).
    RegisterField probe_start;
    RegisterField probe_end;
    PositionCompare compare;

    Action move;
    Action home;
    Action stop;
    Action reset_alarm;

    ProfileTimeouts timeouts;
    AlarmCodes alarm_codes;
};

/// Parses a profile from JSON text; `source_name` prefixes errors ("oriental-az.json:
/// registers.position.width: 24 not in {16, 32}").
Expected<AxisProfile> parse_axis_profile(const std::string& json_text,
                                         const std::string& source_name);

/// Loads a profile by name (data/devices/<name>.json, found with find_data_file) or by path (any
/// string containing '/' or ending in ".json").
Expected<AxisProfile> load_axis_profile(const std::string& name_or_path);

/// The wire (PDU) address of a documented address; an error when it falls outside 0..65535.
Expected<int> wire_address(const AxisProfile& p, int documented);

/// Splits a value into 1 or 2 registers in the profile's word order (two's complement).
std::vector<std::uint16_t> encode_value(std::int64_t value, int width, WordOrder order);

/// Combines 1 or 2 registers (in the profile's word order) into a value, sign-extended when
/// `is_signed`. Combined by hand: libmodbus before 3.1.7 mishandles negative 32-bit values.
std::int64_t decode_value(const std::uint16_t* words, int width, bool is_signed, WordOrder order);

/// The quantities a block can carry (steps and steps/s units).
struct BlockInputs {
    std::int64_t target_steps = 0;
    double speed_steps_per_s = 0;
    double accel_steps_per_s2 = 0;
    double decel_steps_per_s2 = 0;
};

/// Encodes a command block; errors when a value does not fit its field or an inverse quantity is 0.
Expected<std::vector<std::uint16_t>> encode_block(const AxisProfile& p,
                                                  const CommandBlock& block,
                                                  const BlockInputs& in);

/// Decodes a command block from its registers (the simulator's side). Constants are not checked.
BlockInputs decode_block(const AxisProfile& p,
                         const CommandBlock& block,
                         const std::uint16_t* words);

/// Steps <-> degrees with the profile's scale and direction.
std::int64_t degrees_to_steps(const AxisProfile& p, double deg);
double steps_to_degrees(const AxisProfile& p, double steps);

}  // namespace gonio::devices
