#pragma once
// The public API of tetlod, in one include. Data flows one way:
//   volume -> model (HT/MT) -> container -> model view -> query -> mesh -> writer.
// What each header offers, and which calls are safe on untrusted input, is
// stated at the top of that header. In short: everything that reads a file or
// decodes bytes (open_model, read_volume_file, inspect_container,
// extract_from_container, decode_container, verify_container, the volume
// readers) is safe on hostile input and reports an Error naming the file;
// builders and writers expect trusted, consistent in-memory data.

// Versions: library and container format.
#include "tetlod/version.hpp"
#include "tetlod/threads.hpp"

// Vocabulary: volumes, meshes, errors, safe output files.
#include "tetlod/core/atomic_file.hpp"
#include "tetlod/core/error.hpp"
#include "tetlod/core/output_policy.hpp"
#include "tetlod/core/tet_mesh.hpp"
#include "tetlod/core/tet_mesh_sink.hpp"
#include "tetlod/core/tet_mesh_validation.hpp"
#include "tetlod/core/triangle_mesh.hpp"
#include "tetlod/core/utf8.hpp"
#include "tetlod/core/value_type.hpp"
#include "tetlod/core/volume.hpp"
#include "tetlod/core/volume_planes.hpp"
#include "tetlod/core/zeroed_allocator.hpp"

// Models and their queries.
#include "tetlod/model.hpp"
#include "tetlod/models/isosurface.hpp"
#include "tetlod/models/lod_model.hpp"
#include "tetlod/models/lod_query.hpp"
#include "tetlod/models/query_region.hpp"

// Containers: write, inspect, extract, decode.
#include "tetlod/container.hpp"
#include "tetlod/codecs/lossy_field.hpp"

// Measurements.
#include "tetlod/analysis/container_verify.hpp"
#include "tetlod/analysis/lossy_check.hpp"
#include "tetlod/analysis/lod_deviation.hpp"
#include "tetlod/analysis/mesh_resample.hpp"
#include "tetlod/analysis/mt_bound_check.hpp"
#include "tetlod/analysis/model_stats.hpp"
#include "tetlod/analysis/shape_quality.hpp"
#include "tetlod/analysis/stopwatch.hpp"
#include "tetlod/analysis/text_format.hpp"

// Volume and mesh files.
#include "tetlod/converters/features.hpp"
#include "tetlod/converters/medit_writer.hpp"
#include "tetlod/converters/mesh_format.hpp"
#include "tetlod/converters/mesh_writer.hpp"
#include "tetlod/converters/metaimage.hpp"
#include "tetlod/converters/nrrd.hpp"
#include "tetlod/converters/raw_volume.hpp"
#include "tetlod/converters/sample_volumes.hpp"
#include "tetlod/converters/volume_format.hpp"
#include "tetlod/converters/volume_formats.hpp"
#include "tetlod/converters/volume_read_options.hpp"
#if TETLOD_HAVE_OPENMESH
#include "tetlod/converters/surface_writer.hpp"
#endif
