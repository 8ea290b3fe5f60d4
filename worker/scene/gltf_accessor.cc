#include "worker/scene/gltf_accessor.h"

#include <algorithm>
#include <cstring>
#include <span>
#include <string>

#include "absl/strings/str_cat.h"

namespace impostor::gltf_internal {
namespace {

absl::Status Invalid(std::string_view what, int accessor, std::string_view problem) {
  return absl::InvalidArgumentError(
      absl::StrCat(std::string(what), " (accessor ", accessor, "): ", std::string(problem)));
}

int ComponentSize(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;  // DOUBLE and INT are not glTF 2.0 accessor types
  }
}

int ComponentsOf(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return 1;
    case TINYGLTF_TYPE_VEC2:
      return 2;
    case TINYGLTF_TYPE_VEC3:
      return 3;
    case TINYGLTF_TYPE_VEC4:
      return 4;
    default:
      return 0;  // matrices are never vertex attributes or indices
  }
}

template <typename T>
T Load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // accessors need not be aligned in a hostile file
  return v;
}

float ToFloat(const uint8_t* p, int component_type, bool normalized) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return Load<float>(p);
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const float v = Load<int8_t>(p);
      return normalized ? std::max(v / 127.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
      const float v = Load<uint8_t>(p);
      return normalized ? v / 255.0f : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      const float v = Load<int16_t>(p);
      return normalized ? std::max(v / 32767.0f, -1.0f) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      const float v = Load<uint16_t>(p);
      return normalized ? v / 65535.0f : v;
    }
    default: {  // UNSIGNED_INT
      const double v = Load<uint32_t>(p);
      return static_cast<float>(normalized ? v / 4294967295.0 : v);
    }
  }
}

uint32_t ToIndex(const uint8_t* p, int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return Load<uint8_t>(p);
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return Load<uint16_t>(p);
    default:
      return Load<uint32_t>(p);
  }
}

// The bytes of bufferView `view_index`, checked against its buffer.
absl::StatusOr<std::span<const uint8_t>> ViewBytes(const tinygltf::Model& model, int view_index,
                                                   std::string_view what, int accessor) {
  if (view_index < 0 || static_cast<size_t>(view_index) >= model.bufferViews.size()) {
    return Invalid(what, accessor, absl::StrCat("bufferView ", view_index, " does not exist"));
  }
  const tinygltf::BufferView& view = model.bufferViews[view_index];
  if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size()) {
    return Invalid(what, accessor,
                   absl::StrCat("bufferView ", view_index, " names buffer ", view.buffer,
                                " which does not exist"));
  }
  const std::vector<unsigned char>& data = model.buffers[view.buffer].data;
  if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
    return Invalid(what, accessor,
                   absl::StrCat("bufferView ", view_index, " (byteOffset ", view.byteOffset,
                                ", byteLength ", view.byteLength, ") exceeds buffer ", view.buffer,
                                " of ", data.size(), " bytes"));
  }
  return std::span<const uint8_t>(data.data() + view.byteOffset, view.byteLength);
}

// Where each element of a (dense part of an) accessor lives.
struct DenseLayout {
  const uint8_t* base = nullptr;  // nullptr: no bufferView, elements are zero
  size_t stride = 0;
};

absl::StatusOr<DenseLayout> CheckDense(const tinygltf::Model& model, const tinygltf::Accessor& acc,
                                       int index, size_t element_size, std::string_view what) {
  DenseLayout layout;
  if (acc.bufferView < 0) {
    if (!acc.sparse.isSparse && acc.bufferView != -1) {
      return Invalid(what, index, "negative bufferView");
    }
    return layout;
  }
  absl::StatusOr<std::span<const uint8_t>> bytes = ViewBytes(model, acc.bufferView, what, index);
  if (!bytes.ok()) return bytes.status();
  const size_t view_stride = model.bufferViews[acc.bufferView].byteStride;
  layout.stride = view_stride != 0 ? view_stride : element_size;
  if (layout.stride < element_size) {
    return Invalid(what, index,
                   absl::StrCat("byteStride ", layout.stride, " is smaller than the element (",
                                element_size, " bytes)"));
  }
  if (acc.count > 0) {
    const size_t avail = bytes->size();
    const bool fits = acc.byteOffset <= avail && element_size <= avail - acc.byteOffset &&
                      (acc.count - 1) <= (avail - acc.byteOffset - element_size) / layout.stride;
    if (!fits) {
      return Invalid(what, index,
                     absl::StrCat(acc.count, " elements at byteOffset ", acc.byteOffset,
                                  " with stride ", layout.stride, " exceed bufferView ",
                                  acc.bufferView, " of ", avail, " bytes"));
    }
  }
  layout.base = bytes->data() + acc.byteOffset;
  return layout;
}

// Validated sparse substitution: which elements (indices) get which bytes.
struct SparseLayout {
  int count = 0;
  const uint8_t* indices = nullptr;
  int index_component_type = 0;
  const uint8_t* values = nullptr;
};

absl::StatusOr<SparseLayout> CheckSparse(const tinygltf::Model& model,
                                         const tinygltf::Accessor& acc, int index,
                                         size_t element_size, std::string_view what) {
  SparseLayout layout;
  if (!acc.sparse.isSparse) return layout;
  const auto& sparse = acc.sparse;
  if (sparse.count < 1 || static_cast<size_t>(sparse.count) > acc.count) {
    return Invalid(what, index,
                   absl::StrCat("sparse.count ", sparse.count, " is not in 1..", acc.count));
  }
  const int index_size = ComponentSize(sparse.indices.componentType);
  if (sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
      sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
      sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT || index_size == 0) {
    return Invalid(what, index,
                   absl::StrCat("sparse.indices.componentType ", sparse.indices.componentType,
                                " is not an unsigned integer type"));
  }
  const auto check = [&](int view, int offset, size_t bytes_needed,
                         const char* part) -> absl::StatusOr<const uint8_t*> {
    absl::StatusOr<std::span<const uint8_t>> bytes = ViewBytes(model, view, what, index);
    if (!bytes.ok()) return bytes.status();
    if (offset < 0 || static_cast<size_t>(offset) > bytes->size() ||
        bytes_needed > bytes->size() - static_cast<size_t>(offset)) {
      return Invalid(
          what, index,
          absl::StrCat("sparse.", part, " (", bytes_needed, " bytes at byteOffset ", offset,
                       ") exceed bufferView ", view, " of ", bytes->size(), " bytes"));
    }
    return bytes->data() + offset;
  };
  const size_t n = static_cast<size_t>(sparse.count);
  absl::StatusOr<const uint8_t*> indices =
      check(sparse.indices.bufferView, sparse.indices.byteOffset, n * index_size, "indices");
  if (!indices.ok()) return indices.status();
  absl::StatusOr<const uint8_t*> values =
      check(sparse.values.bufferView, sparse.values.byteOffset, n * element_size, "values");
  if (!values.ok()) return values.status();
  for (size_t i = 0; i < n; ++i) {
    const uint32_t target = ToIndex(*indices + i * index_size, sparse.indices.componentType);
    if (target >= acc.count) {
      return Invalid(what, index, absl::StrCat("sparse index ", target, " >= count ", acc.count));
    }
  }
  layout.count = sparse.count;
  layout.indices = *indices;
  layout.index_component_type = sparse.indices.componentType;
  layout.values = *values;
  return layout;
}

// Shared checks and the element walk: `emit(element, bytes)` is called for
// every dense element and then for every sparse substitution, in that
// order, so later calls overwrite earlier ones.
template <typename Emit>
absl::Status Walk(const tinygltf::Model& model, int index, int expected_type, uint64_t max_count,
                  std::string_view what, size_t* count_out, Emit emit) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": accessor ", index, " does not exist"));
  }
  const tinygltf::Accessor& acc = model.accessors[index];
  if (acc.type != expected_type) {
    return Invalid(what, index,
                   absl::StrCat("type ", acc.type, " is not the expected ", expected_type));
  }
  const int component_size = ComponentSize(acc.componentType);
  if (component_size == 0) {
    return Invalid(what, index, absl::StrCat("componentType ", acc.componentType, " is invalid"));
  }
  // Checked before anything is allocated: an accessor without a bufferView
  // is all zeros, so `count` alone would size the output (issue 23).
  if (acc.count > max_count) {
    return absl::ResourceExhaustedError(
        absl::StrCat(std::string(what), " (accessor ", index, "): count ", acc.count,
                     " exceeds the ", max_count, " elements this read allows"));
  }
  const size_t element_size = static_cast<size_t>(component_size) * ComponentsOf(acc.type);
  absl::StatusOr<DenseLayout> dense = CheckDense(model, acc, index, element_size, what);
  if (!dense.ok()) return dense.status();
  absl::StatusOr<SparseLayout> sparse = CheckSparse(model, acc, index, element_size, what);
  if (!sparse.ok()) return sparse.status();

  *count_out = acc.count;
  if (dense->base != nullptr) {
    for (size_t i = 0; i < acc.count; ++i) emit(i, dense->base + i * dense->stride);
  }
  const size_t index_size = ComponentSize(sparse->index_component_type);
  for (int i = 0; i < sparse->count; ++i) {
    const uint32_t target = ToIndex(sparse->indices + i * index_size, sparse->index_component_type);
    emit(target, sparse->values + i * element_size);
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::vector<float>> ReadFloatAccessor(const tinygltf::Model& model, int index,
                                                     int expected_type, uint64_t max_count,
                                                     std::string_view what) {
  const int components = ComponentsOf(expected_type);
  std::vector<float> out;
  size_t count = 0;
  int component_type = 0;
  bool normalized = false;
  size_t component_size = 0;
  if (index >= 0 && static_cast<size_t>(index) < model.accessors.size()) {
    component_type = model.accessors[index].componentType;
    normalized = model.accessors[index].normalized;
    component_size = ComponentSize(component_type);
  }
  absl::Status status =
      Walk(model, index, expected_type, max_count, what, &count,
           [&](size_t element, const uint8_t* bytes) {
             if (out.empty()) out.assign(count * components, 0.0f);
             float* dst = out.data() + element * components;
             for (int c = 0; c < components; ++c) {
               dst[c] = ToFloat(bytes + c * component_size, component_type, normalized);
             }
           });
  if (!status.ok()) return status;
  out.resize(count * components, 0.0f);  // all-zero accessor (no view, no sparse)
  return out;
}

absl::StatusOr<std::vector<uint32_t>> ReadIndexAccessor(const tinygltf::Model& model, int index,
                                                        uint64_t max_count, std::string_view what) {
  if (index >= 0 && static_cast<size_t>(index) < model.accessors.size()) {
    const int ct = model.accessors[index].componentType;
    if (ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT) {
      return Invalid(what, index,
                     absl::StrCat("index componentType ", ct, " is not UNSIGNED_BYTE/SHORT/INT"));
    }
  }
  std::vector<uint32_t> out;
  size_t count = 0;
  const int ct = index >= 0 && static_cast<size_t>(index) < model.accessors.size()
                     ? model.accessors[index].componentType
                     : 0;
  absl::Status status = Walk(model, index, TINYGLTF_TYPE_SCALAR, max_count, what, &count,
                             [&](size_t element, const uint8_t* bytes) {
                               if (out.empty()) out.assign(count, 0u);
                               out[element] = ToIndex(bytes, ct);
                             });
  if (!status.ok()) return status;
  out.resize(count, 0u);
  return out;
}

absl::StatusOr<uint64_t> AccessorCount(const tinygltf::Model& model, int index,
                                       std::string_view what) {
  if (index < 0 || static_cast<size_t>(index) >= model.accessors.size()) {
    return absl::InvalidArgumentError(
        absl::StrCat(std::string(what), ": accessor ", index, " does not exist"));
  }
  return static_cast<uint64_t>(model.accessors[index].count);
}

}  // namespace impostor::gltf_internal
