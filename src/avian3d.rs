#![doc = include_str!("avian/docs.md")]
//!
//! This module is for `avian3d` (feature `avian3d`).

use ::avian3d::math::Dir;
use ::avian3d::prelude::*;

/// A body-local anchor (3D).
pub type Anchor = Vec3;

macro_rules! module_name_doc {
    () => {
        "avian3d"
    };
}

fn to_d(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

fn from_d(v: DVec3) -> Vec3 {
    v.as_vec3()
}

/// A body's `Transform` translation for centre `v`.
fn translation_from_d(v: DVec3, _: Vec3) -> Vec3 {
    v.as_vec3()
}

fn rotation_d(rotation: &Rotation) -> DQuat {
    rotation.0.as_dquat()
}

fn rotation_from_d(rotation: DQuat) -> Rotation {
    Rotation(rotation.as_quat())
}

fn angular_d(angular: &AngularVelocity) -> DVec3 {
    angular.0.as_dvec3()
}

fn angular_from_d(angular: DVec3) -> Vec3 {
    angular.as_vec3()
}

fn inverse_inertia_d(inertia: &ComputedAngularInertia, rotation: DQuat) -> DMat3 {
    inertia
        .rotated(rotation.as_quat())
        .inverse()
        .to_mat3()
        .as_dmat3()
}

/// Whether any translation axis, and whether any rotation axis, is locked.
fn any_locked(locked: &LockedAxes) -> (bool, bool) {
    let translation = locked.is_translation_x_locked()
        || locked.is_translation_y_locked()
        || locked.is_translation_z_locked();
    let rotation = locked.is_rotation_x_locked()
        || locked.is_rotation_y_locked()
        || locked.is_rotation_z_locked();
    (translation, rotation)
}

/// 3D bounds as they are.
fn full_depth(lo: DVec3, hi: DVec3) -> (DVec3, DVec3) {
    (lo, hi)
}

/// A 3D surface point as it is.
fn keep_depth(surface: DVec3, _: DVec3) -> DVec3 {
    surface
}

include!("avian/common.rs");
