// The binding points of the deformation shaders (internal to deform/), as each
// shader declares them with layout(binding = N) in deform/shaders/: a change
// on one side must be made on the other (the shaders name these constants in
// comments beside their declarations).
#pragma once
#include <crumple/gl/bindings.h>

namespace crumple::deform::bindings {

// Every update and the commit: the sides' touched regions (ivec4 a slot) and the scratch of new heights
// (Scratch::bind).
inline constexpr gl::StorageBinding kRegion{0}, kScratch{2};

// address.frag, address_bin.comp, address_raster.comp.
namespace address {
inline constexpr gl::TextureUnit kHeights{0};  // address.frag's uHeight; address_raster.comp's uHeights[16]
inline constexpr gl::ImageUnit kAddress{0}, kDepth{1};  // address_raster.comp: pass B's targets (arrays)
inline constexpr gl::StorageBinding kVertices{0}, kIndices{1}, kSetup{2}, kTileCount{3}, kTileList{4}, kLarge{5},
    kActive{6}, kEntries{7}, kArgs{8}, kReach{9};
}  // namespace address

// texel_gather.frag and dent_update.comp (one side: X's and the other's address-pass targets, X's height map).
namespace update {
inline constexpr gl::TextureUnit kAddressX{0}, kDepthX{1}, kAddressOther{2}, kDepthOther{3}, kNormalX{4},
    kHeightX{5};
}  // namespace update

// texel_gather.comp.
namespace gather {
inline constexpr gl::TextureUnit kAddressOthers{0}, kDepthOthers{1}, kHeights{2};  // kHeights: uHeights[14]
inline constexpr gl::StorageBinding kVertices{1}, kIndices{3}, kTileStart{4}, kTileTriangles{5}, kTileBoxes{6},
    kEntries{7}, kKept{8}, kReach{9}, kKeptHead{10};
}  // namespace gather

// rim_dispatch.comp, crater_rim.comp.
namespace rim {
inline constexpr gl::TextureUnit kHeight{1};
inline constexpr gl::StorageBinding kSums{4}, kRim{5};
}  // namespace rim

// region_dispatch.comp, dent_commit.comp, normal_map.comp, height_bound.comp, height_bound_up.comp (arrays of
// 8 maps at their units). region_dispatch.comp writes its dispatch sizes at kArgs, where the others read the
// scratch (kScratch).
namespace commit {
inline constexpr gl::TextureUnit kHeights{0};  // normal_map.comp's and height_bound.comp's uHeightMaps[8]
inline constexpr gl::ImageUnit kMaps{0};       // dent_commit.comp's uHeights, normal_map.comp's uNormals,
                                               // height_bound(_up).comp's uBounds [8]
inline constexpr gl::StorageBinding kStats{1}, kArgs{2}, kNormalRegion{3}, kRim{5}, kEntries{6}, kChanges{7};
}  // namespace commit

// crease_bevel.comp.
namespace bevel {
inline constexpr gl::TextureUnit kHeight{0};
inline constexpr gl::StorageBinding kUvs{0}, kLinks{1}, kOwn{2}, kFrom{3}, kTo{4}, kFrames{5};
}  // namespace bevel

namespace levels {
inline constexpr gl::ImageUnit kTo{0}, kFrom{1};
inline constexpr gl::StorageBinding kCover{0};
}  // namespace levels

}  // namespace crumple::deform::bindings
