// A test fixture, not shipped: an empty shared object linked with -z nodelete that depends on
// Debian's OniFile driver (libOniFile.so.0, .oni playback). The ASan build's private OpenNI2
// runtime (tests/drivers/CMakeLists.txt) loads this in OniFile's place; OpenNI2 finds the driver's
// entry points through it (dlsym searches a library's dependencies) and its dlclose at
// OpenNI::shutdown() cannot unload OniFile any more. OniFile keeps some of its allocations only in
// its own globals, so unloading it left them unreferenced and LeakSanitizer reported them, with
// stacks that end in "<unknown module>" (nothing a suppression can name). Kept loaded, they are
// reachable, as in a process that never shuts OpenNI2 down.
namespace palletd::test {
extern const int kOniFileKeep;
const int kOniFileKeep = 1;
}  // namespace palletd::test
