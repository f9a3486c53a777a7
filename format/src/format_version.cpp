// Placeholder translation unit so the library exists before the container lands.
namespace tetlod::format_detail {
int format_library_anchor() { return 0; }
}  // namespace tetlod::format_detail
