// Names and units of the columns `hexa_recorder export` writes (docs/recorder.md, "CLI").
// Every header cell is "name [unit]": SI units (m, rad, s, ns, Pa, V, N, kg, Hz and their
// products), "1" for a dimensionless number (counts, ids, tick numbers, flags, quaternion
// components, scale factors) and "-" for text (strings, enum names). A field the table does not
// know gets "?", which the tests reject for every field of the recording schemas.
#pragma once

#include <string>
#include <vector>

#include <google/protobuf/descriptor.h>

namespace hexa::recorder {

// Unit of a scalar leaf field, or of element `index` of a repeated one ("?" when unknown).
std::string ColumnUnit(const google::protobuf::FieldDescriptor& leaf, int index);

// Name of element `index` of a repeated field: the component it holds where the schema fixes
// it (desired_pose.x, orientation_wxyz.w, position_m.z, leg_length_m.leg3), else name[index].
std::string ElementName(const google::protobuf::FieldDescriptor& field, int index);

// What one exported file holds (the sidecar README.txt): by message type, one sentence.
std::string MessageDescription(const std::string& full_name);

}  // namespace hexa::recorder
