// The simulated GigE Vision camera's GenICam description (GenApi schema 1.1), written from the
// GenICam standard and the SFNC feature names. It deliberately uses the node types real cameras
// use, so that a host's GenICam engine is exercised as a lab camera would exercise it:
//   - pAddress: the region-of-interest registers sit in a block whose base address is read from a
//     pointer register;
//   - pIndex: Gain and DeviceTemperature read tables indexed by GainSelector and
//     DeviceTemperatureSelector;
//   - Converter: the exposure time in us from a raw register counting 100 ns ticks (tick length
//     read from the device), the gain in dB from a register in 0.01 dB;
//   - SwissKnife: DeviceTemperature from a raw register in 1/16 deg C;
//   - IntSwissKnife: PayloadSize and the width/height/offset bounds;
//   - StructReg/StructEntry: trigger selector, mode, activation and source in one register;
//   - MaskedIntReg: TLParamsLocked and AcquisitionMode sharing one register;
//   - Enumeration with pValue for every enumeration;
//   - the exposure feature named ExposureTime (SFNC) or ExposureTimeAbs (older GigE cameras).

#include <cstdio>
#include <sstream>

#include "gonio/devices/gvcp.h"
#include "gonio/devices/pixel_format.h"
#include "gonio/sim/gige_camera.h"

namespace gonio::sim {

namespace {

std::string hex(std::uint64_t v) {
    char b[32];
    std::snprintf(b, sizeof b, "0x%llX", static_cast<unsigned long long>(v));
    return b;
}

class XmlWriter {
  public:
    std::ostringstream x;

    void int_reg(const std::string& name,
                 const std::string& address_elements,
                 const char* access,
                 int length = 4,
                 bool is_signed = false) {
        x << "  <IntReg Name=\"" << name << "\">\n"
          << "    <Visibility>Invisible</Visibility>\n"
          << address_elements << "    <Length>" << length << "</Length>\n"
          << "    <AccessMode>" << access << "</AccessMode>\n"
          << "    <pPort>Device</pPort>\n"
          << "    <Cachable>NoCache</Cachable>\n"
          << "    <Sign>" << (is_signed ? "Signed" : "Unsigned") << "</Sign>\n"
          << "    <Endianess>BigEndian</Endianess>\n"
          << "  </IntReg>\n";
    }

    static std::string at(std::uint64_t address) {
        return "    <Address>" + hex(address) + "</Address>\n";
    }

    void integer(const std::string& name,
                 const std::string& tooltip,
                 const std::string& value,
                 const std::string& min,
                 const std::string& max,
                 const std::string& extra = "") {
        x << "  <Integer Name=\"" << name << "\">\n"
          << "    <ToolTip>" << tooltip << "</ToolTip>\n"
          << extra << "    " << value << "\n    " << min << "\n    " << max << "\n"
          << "  </Integer>\n";
    }

    void enumeration(const std::string& name,
                     const std::string& tooltip,
                     const std::vector<std::pair<std::string, std::uint64_t>>& entries,
                     const std::string& p_value,
                     const std::string& extra = "") {
        x << "  <Enumeration Name=\"" << name << "\">\n"
          << "    <ToolTip>" << tooltip << "</ToolTip>\n"
          << extra;
        for (const auto& [entry, value] : entries) {
            x << "    <EnumEntry Name=\"" << entry << "\">\n"
              << "      <Value>" << hex(value) << "</Value>\n"
              << "    </EnumEntry>\n";
        }
        x << "    <pValue>" << p_value << "</pValue>\n"
          << "  </Enumeration>\n";
    }

    void command(const std::string& name, const std::string& tooltip, const std::string& reg) {
        x << "  <Command Name=\"" << name << "\">\n"
          << "    <ToolTip>" << tooltip << "</ToolTip>\n"
          << "    <pValue>" << reg << "</pValue>\n"
          << "    <CommandValue>1</CommandValue>\n"
          << "  </Command>\n";
    }

    void string_reg(const std::string& name, std::uint32_t address, int length, const char* acc) {
        x << "  <StringReg Name=\"" << name << "\">\n"
          << "    <Address>" << hex(address) << "</Address>\n"
          << "    <Length>" << length << "</Length>\n"
          << "    <AccessMode>" << acc << "</AccessMode>\n"
          << "    <pPort>Device</pPort>\n"
          << "  </StringReg>\n";
    }

    void float_reg(const std::string& name, std::uint32_t address, const char* access) {
        x << "  <FloatReg Name=\"" << name << "\">\n"
          << "    <Visibility>Invisible</Visibility>\n"
          << "    <Address>" << hex(address) << "</Address>\n"
          << "    <Length>4</Length>\n"
          << "    <AccessMode>" << access << "</AccessMode>\n"
          << "    <pPort>Device</pPort>\n"
          << "    <Cachable>NoCache</Cachable>\n"
          << "    <Endianess>BigEndian</Endianess>\n"
          << "  </FloatReg>\n";
    }

    void masked(const std::string& name,
                std::uint32_t address,
                const std::string& bits,
                const char* access = "RW") {
        x << "  <MaskedIntReg Name=\"" << name << "\">\n"
          << "    <Visibility>Invisible</Visibility>\n"
          << "    <Address>" << hex(address) << "</Address>\n"
          << "    <Length>4</Length>\n"
          << "    <AccessMode>" << access << "</AccessMode>\n"
          << "    <pPort>Device</pPort>\n"
          << "    <Cachable>NoCache</Cachable>\n"
          << bits << "    <Sign>Unsigned</Sign>\n"
          << "    <Endianess>BigEndian</Endianess>\n"
          << "  </MaskedIntReg>\n";
    }

    void category(const std::string& name, const std::vector<std::string>& features) {
        x << "  <Category Name=\"" << name << "\">\n";
        for (const std::string& f : features) {
            x << "    <pFeature>" << f << "</pFeature>\n";
        }
        x << "  </Category>\n";
    }
};

void write_categories(XmlWriter& w, const std::string& exposure) {
    w.category("Root",
               {"DeviceControl",
                "ImageFormatControl",
                "AcquisitionControl",
                "AnalogControl",
                "TransportLayerControl"});
    w.category("DeviceControl",
               {"DeviceVendorName",
                "DeviceModelName",
                "DeviceVersion",
                "DeviceSerialNumber",
                "DeviceUserID",
                "DeviceTemperatureSelector",
                "DeviceTemperature"});
    w.category("ImageFormatControl",
               {"SensorWidth",
                "SensorHeight",
                "WidthMax",
                "HeightMax",
                "Width",
                "Height",
                "OffsetX",
                "OffsetY",
                "PixelFormat"});
    w.category("AcquisitionControl",
               {"AcquisitionMode",
                "AcquisitionStart",
                "AcquisitionStop",
                "AcquisitionFrameRate",
                "TriggerSelector",
                "TriggerMode",
                "TriggerSource",
                "TriggerActivation",
                "TriggerSoftware",
                exposure,
                "ExposureTimeRaw"});
    w.category("AnalogControl", {"GainSelector", "Gain", "GainRaw", "BlackLevel"});
    w.category("TransportLayerControl",
               {"PayloadSize",
                "TLParamsLocked",
                "GevTimestampTickFrequency",
                "GevTimestampControlLatch",
                "GevTimestampValue",
                "GevHeartbeatTimeout",
                "GevSCPSPacketSize"});
}

void write_device_control(XmlWriter& w) {
    namespace m = gige_map;
    auto& x = w.x;
    // Device identity: the bootstrap strings.
    w.string_reg("DeviceVendorName", devices::gvbs::kManufacturerName, 32, "RO");
    w.string_reg("DeviceModelName", devices::gvbs::kModelName, 32, "RO");
    w.string_reg("DeviceVersion", devices::gvbs::kDeviceVersion, 32, "RO");
    w.string_reg("DeviceSerialNumber", devices::gvbs::kSerialNumber, 16, "RO");
    w.string_reg("DeviceUserID", devices::gvbs::kUserDefinedName, 16, "RW");

    // Temperatures: a table indexed by the selector (pIndex), converted by a SwissKnife.
    w.enumeration("DeviceTemperatureSelector",
                  "Which temperature DeviceTemperature reports",
                  {{"Sensor", 0}, {"Mainboard", 1}},
                  "DeviceTemperatureSelectorReg");
    w.int_reg("DeviceTemperatureSelectorReg", XmlWriter::at(m::kTemperatureSelector), "RW");
    w.int_reg("DeviceTemperatureRawReg",
              XmlWriter::at(m::kTemperatureTable) +
                  "    <pIndex Offset=\"4\">DeviceTemperatureSelectorReg</pIndex>\n",
              "RO",
              4,
              true);
    x << "  <SwissKnife Name=\"DeviceTemperature\">\n"
      << "    <ToolTip>Temperature at the selected place</ToolTip>\n"
      << "    <pVariable Name=\"RAW\">DeviceTemperatureRawReg</pVariable>\n"
      << "    <Formula>RAW/16</Formula>\n"
      << "    <Unit>C</Unit>\n"
      << "  </SwissKnife>\n";
}

void write_image_format(XmlWriter& w) {
    namespace m = gige_map;
    auto& x = w.x;
    // Image format: the ROI block is found through a pointer register (pAddress).
    w.int_reg("RoiBlockAddress", XmlWriter::at(m::kRoiBasePointer), "RO");
    const auto roi_reg = [&](const std::string& name, int offset) {
        w.int_reg(name, XmlWriter::at(offset) + "    <pAddress>RoiBlockAddress</pAddress>\n", "RW");
    };
    roi_reg("WidthReg", 0);
    roi_reg("HeightReg", 4);
    roi_reg("OffsetXReg", 8);
    roi_reg("OffsetYReg", 12);
    w.int_reg("SensorWidthReg", XmlWriter::at(m::kSensorWidth), "RO");
    w.int_reg("SensorHeightReg", XmlWriter::at(m::kSensorHeight), "RO");
    const std::string locked = "    <pIsLocked>TLParamsLocked</pIsLocked>\n";
    w.integer("SensorWidth",
              "Effective sensor width, pixels",
              "<pValue>SensorWidthReg</pValue>",
              "<Min>1</Min>",
              "<Max>65535</Max>");
    w.integer("SensorHeight",
              "Effective sensor height, pixels",
              "<pValue>SensorHeightReg</pValue>",
              "<Min>1</Min>",
              "<Max>65535</Max>");
    w.integer("WidthMax",
              "Largest image width, pixels",
              "<pValue>SensorWidthReg</pValue>",
              "<Min>1</Min>",
              "<Max>65535</Max>");
    w.integer("HeightMax",
              "Largest image height, pixels",
              "<pValue>SensorHeightReg</pValue>",
              "<Min>1</Min>",
              "<Max>65535</Max>");
    const auto bound = [&](const std::string& name,
                           const std::string& a,
                           const std::string& b,
                           const std::string& formula) {
        x << "  <IntSwissKnife Name=\"" << name << "\">\n"
          << "    <Visibility>Invisible</Visibility>\n"
          << "    <pVariable Name=\"A\">" << a << "</pVariable>\n"
          << "    <pVariable Name=\"B\">" << b << "</pVariable>\n"
          << "    <Formula>" << formula << "</Formula>\n"
          << "  </IntSwissKnife>\n";
    };
    bound("WidthBound", "SensorWidthReg", "OffsetXReg", "A-B");
    bound("HeightBound", "SensorHeightReg", "OffsetYReg", "A-B");
    bound("OffsetXBound", "SensorWidthReg", "WidthReg", "A-B");
    bound("OffsetYBound", "SensorHeightReg", "HeightReg", "A-B");
    w.integer("Width",
              "Image width, pixels",
              "<pValue>WidthReg</pValue>",
              "<Min>1</Min>",
              "<pMax>WidthBound</pMax>",
              locked);
    w.integer("Height",
              "Image height, pixels",
              "<pValue>HeightReg</pValue>",
              "<Min>1</Min>",
              "<pMax>HeightBound</pMax>",
              locked);
    w.integer("OffsetX",
              "Horizontal offset of the region of interest, pixels",
              "<pValue>OffsetXReg</pValue>",
              "<Min>0</Min>",
              "<pMax>OffsetXBound</pMax>",
              locked);
    w.integer("OffsetY",
              "Vertical offset of the region of interest, pixels",
              "<pValue>OffsetYReg</pValue>",
              "<Min>0</Min>",
              "<pMax>OffsetYBound</pMax>",
              locked);
    w.enumeration("PixelFormat",
                  "Format of the pixels in the stream",
                  {{"Mono8", devices::kPfncMono8},
                   {"Mono12", devices::kPfncMono12},
                   {"Mono16", devices::kPfncMono16}},
                  "PixelFormatReg",
                  locked);
    w.int_reg("PixelFormatReg", XmlWriter::at(m::kPixelFormat), "RW");
}

void write_acquisition(XmlWriter& w) {
    namespace m = gige_map;
    auto& x = w.x;
    // Acquisition.
    w.masked("TLParamsLockedReg", m::kAcquisitionControl, "    <Bit>31</Bit>\n");
    w.masked(
        "AcquisitionModeReg", m::kAcquisitionControl, "    <LSB>23</LSB>\n    <MSB>16</MSB>\n");
    w.integer("TLParamsLocked",
              "Locks the transport-layer parameters during acquisition",
              "<pValue>TLParamsLockedReg</pValue>",
              "<Min>0</Min>",
              "<Max>1</Max>");
    w.enumeration("AcquisitionMode",
                  "Continuous or single-frame acquisition",
                  {{"Continuous", 0}, {"SingleFrame", 1}},
                  "AcquisitionModeReg");
    w.command("AcquisitionStart", "Starts the acquisition", "AcquisitionStartReg");
    w.command("AcquisitionStop", "Stops the acquisition", "AcquisitionStopReg");
    w.command("TriggerSoftware", "Fires the software trigger", "TriggerSoftwareReg");
    w.int_reg("AcquisitionStartReg", XmlWriter::at(m::kAcquisitionStart), "WO");
    w.int_reg("AcquisitionStopReg", XmlWriter::at(m::kAcquisitionStop), "WO");
    w.int_reg("TriggerSoftwareReg", XmlWriter::at(m::kTriggerSoftware), "WO");
    x << "  <Float Name=\"AcquisitionFrameRate\">\n"
      << "    <ToolTip>Frame rate of continuous acquisition</ToolTip>\n"
      << "    <pValue>AcquisitionFrameRateReg</pValue>\n"
      << "    <Min>0.1</Min>\n    <Max>200</Max>\n    <Unit>Hz</Unit>\n"
      << "  </Float>\n";
    w.float_reg("AcquisitionFrameRateReg", m::kFrameRate, "RW");
    // One trigger-control register, four fields.
    x << "  <StructReg Comment=\"Trigger control\">\n"
      << "    <Address>" << hex(m::kTriggerControl) << "</Address>\n"
      << "    <Length>4</Length>\n    <AccessMode>RW</AccessMode>\n"
      << "    <pPort>Device</pPort>\n    <Cachable>NoCache</Cachable>\n"
      << "    <Endianess>BigEndian</Endianess>\n"
      << "    <StructEntry Name=\"TriggerSelectorReg\">\n      <LSB>7</LSB>\n      <MSB>0</MSB>\n"
      << "    </StructEntry>\n"
      << "    <StructEntry Name=\"TriggerActivationReg\">\n      <LSB>15</LSB>\n"
      << "      <MSB>8</MSB>\n    </StructEntry>\n"
      << "    <StructEntry Name=\"TriggerSourceReg\">\n      <LSB>23</LSB>\n      <MSB>16</MSB>\n"
      << "    </StructEntry>\n"
      << "    <StructEntry Name=\"TriggerModeReg\">\n      <Bit>31</Bit>\n    </StructEntry>\n"
      << "  </StructReg>\n";
    w.enumeration(
        "TriggerSelector", "Trigger to configure", {{"FrameStart", 0}}, "TriggerSelectorReg");
    w.enumeration("TriggerMode",
                  "Frames on trigger (On) or free-running (Off)",
                  {{"Off", 0}, {"On", 1}},
                  "TriggerModeReg");
    w.enumeration("TriggerSource",
                  "Source of the trigger: TriggerSoftware, or the trigger input line (wired to a "
                  "drive's position compare output)",
                  {{"Software", 0}, {"Line1", 1}},
                  "TriggerSourceReg");
    w.enumeration("TriggerActivation",
                  "Edge of the line pulse that starts the exposure",
                  {{"RisingEdge", 0}, {"FallingEdge", 1}},
                  "TriggerActivationReg");
}

void write_exposure(XmlWriter& w, const std::string& exposure) {
    namespace m = gige_map;
    auto& x = w.x;
    // Exposure: 100 ns ticks in the register, microseconds through a Converter.
    w.int_reg("ExposureTimeRawReg", XmlWriter::at(m::kExposureTicks), "RW");
    w.int_reg("ExposureTickReg", XmlWriter::at(m::kExposureTickNs), "RO");
    w.integer("ExposureTimeRaw",
              "Exposure time in device ticks (see the tick length)",
              "<pValue>ExposureTimeRawReg</pValue>",
              "<Min>100</Min>",
              "<Max>100000000</Max>");
    x << "  <Converter Name=\"" << exposure << "\">\n"
      << "    <ToolTip>Exposure time</ToolTip>\n"
      << "    <pVariable Name=\"TICKNS\">ExposureTickReg</pVariable>\n"
      << "    <FormulaTo>FROM*1000/TICKNS</FormulaTo>\n"
      << "    <FormulaFrom>TO*TICKNS/1000</FormulaFrom>\n"
      << "    <pValue>ExposureTimeRaw</pValue>\n"
      << "    <Unit>us</Unit>\n"
      << "    <Slope>Increasing</Slope>\n"
      << "  </Converter>\n";
}

void write_analog(XmlWriter& w) {
    namespace m = gige_map;
    auto& x = w.x;
    // Gain: a table indexed by the selector (pIndex), 0.01 dB per count, dB through a Converter.
    w.enumeration("GainSelector",
                  "Which gain Gain sets (the sensor sees their sum in dB)",
                  {{"AnalogAll", 0}, {"DigitalAll", 1}},
                  "GainSelectorReg");
    w.int_reg("GainSelectorReg", XmlWriter::at(m::kGainSelector), "RW");
    w.int_reg("GainRawReg",
              XmlWriter::at(m::kGainTable) + "    <pIndex Offset=\"4\">GainSelectorReg</pIndex>\n",
              "RW");
    w.integer("GainRaw",
              "Gain in 0.01 dB",
              "<pValue>GainRawReg</pValue>",
              "<Min>0</Min>",
              "<Max>2400</Max>");
    x << "  <Converter Name=\"Gain\">\n"
      << "    <ToolTip>Gain of the selected stage</ToolTip>\n"
      << "    <FormulaTo>FROM*100</FormulaTo>\n"
      << "    <FormulaFrom>TO/100</FormulaFrom>\n"
      << "    <pValue>GainRaw</pValue>\n"
      << "    <Unit>dB</Unit>\n"
      << "    <Slope>Increasing</Slope>\n"
      << "  </Converter>\n";
    x << "  <Float Name=\"BlackLevel\">\n"
      << "    <ToolTip>Black level of the current pixel format</ToolTip>\n"
      << "    <pValue>BlackLevelReg</pValue>\n"
      << "    <Min>0</Min>\n    <Max>65535</Max>\n    <Unit>DN</Unit>\n"
      << "  </Float>\n";
    w.float_reg("BlackLevelReg", m::kBlackLevel, "RO");
}

void write_transport_layer(XmlWriter& w) {
    auto& x = w.x;
    // Transport layer.
    x << "  <IntSwissKnife Name=\"PayloadSize\">\n"
      << "    <ToolTip>Bytes of one image (bits per pixel from the PFNC code)</ToolTip>\n"
      << "    <pVariable Name=\"W\">WidthReg</pVariable>\n"
      << "    <pVariable Name=\"H\">HeightReg</pVariable>\n"
      << "    <pVariable Name=\"PF\">PixelFormatReg</pVariable>\n"
      << "    <Formula>W*H*((PF&gt;&gt;16)&amp;255)/8</Formula>\n"
      << "  </IntSwissKnife>\n";
    w.int_reg("GevTimestampTickFrequencyReg",
              XmlWriter::at(devices::gvbs::kTimestampTickFrequencyHigh),
              "RO",
              8);
    w.integer("GevTimestampTickFrequency",
              "Timestamp ticks per second",
              "<pValue>GevTimestampTickFrequencyReg</pValue>",
              "<Min>0</Min>",
              "<Max>9223372036854775807</Max>");
    w.int_reg("GevTimestampControlReg", XmlWriter::at(devices::gvbs::kTimestampControl), "WO");
    x << "  <Command Name=\"GevTimestampControlLatch\">\n"
      << "    <ToolTip>Latches the timestamp into GevTimestampValue</ToolTip>\n"
      << "    <pValue>GevTimestampControlReg</pValue>\n"
      << "    <CommandValue>2</CommandValue>\n"
      << "  </Command>\n";
    w.int_reg("GevTimestampValueReg", XmlWriter::at(devices::gvbs::kTimestampValueHigh), "RO", 8);
    w.integer("GevTimestampValue",
              "Latched timestamp, ticks",
              "<pValue>GevTimestampValueReg</pValue>",
              "<Min>0</Min>",
              "<Max>9223372036854775807</Max>");
    w.int_reg("GevHeartbeatTimeoutReg", XmlWriter::at(devices::gvbs::kHeartbeatTimeout), "RW");
    w.integer("GevHeartbeatTimeout",
              "Control is released after this long without a command from its holder, ms",
              "<pValue>GevHeartbeatTimeoutReg</pValue>",
              "<Min>500</Min>",
              "<Max>4294967295</Max>");
    w.masked("GevSCPSPacketSizeReg",
             devices::gvbs::kStreamChannelPacketSize,
             "    <LSB>31</LSB>\n    <MSB>16</MSB>\n");
    x << "  <Integer Name=\"GevSCPSPacketSize\">\n"
      << "    <ToolTip>Stream packet size, bytes including IP, UDP and GVSP headers</ToolTip>\n"
      << "    <pIsLocked>TLParamsLocked</pIsLocked>\n"
      << "    <pValue>GevSCPSPacketSizeReg</pValue>\n"
      << "    <Min>576</Min>\n    <Max>65500</Max>\n    <Inc>4</Inc>\n"
      << "  </Integer>\n";
}
}  // namespace

std::string gige_camera_xml(const GigeCameraConfig& c) {
    XmlWriter w;
    auto& x = w.x;
    const std::string exposure =
        c.exposure_naming == ExposureNaming::kAbs ? "ExposureTimeAbs" : "ExposureTime";
    x << "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
      << "<!-- GenICam description of the gonio simulated GigE Vision camera -->\n"
      << "<RegisterDescription ModelName=\"" << c.model << "\" VendorName=\"" << c.vendor
      << "\" ToolTip=\"Simulated GigE Vision camera rendering a ground-truth BRDF\""
      << " StandardNameSpace=\"GEV\" SchemaMajorVersion=\"1\" SchemaMinorVersion=\"1\""
      << " SchemaSubMinorVersion=\"0\" MajorVersion=\"1\" MinorVersion=\"0\""
      << " SubMinorVersion=\"0\" ProductGuid=\"6f1c3a52-0b2e-4f7d-9a41-3c5d2e8b7a10\""
      << " VersionGuid=\"0d9e4b71-5a3c-4e2f-8b16-7c2a9f4e3d58\""
      << " xmlns=\"http://www.genicam.org/GenApi/Version_1_1\""
      << " xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\">\n";
    write_categories(w, exposure);
    write_device_control(w);
    write_image_format(w);
    write_acquisition(w);
    write_exposure(w, exposure);
    write_analog(w);
    write_transport_layer(w);
    x << "  <Port Name=\"Device\">\n    <ToolTip>The camera's register space</ToolTip>\n"
      << "  </Port>\n"
      << "</RegisterDescription>\n";
    return x.str();
}

}  // namespace gonio::sim
