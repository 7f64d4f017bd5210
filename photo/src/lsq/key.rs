//! Typed keys of parameter blocks: a block is named by what it is (the pose of image 3, object
//! point 17, the lever arm of camera 0), never by its position in the solver's arrays.

use std::fmt;

macro_rules! id {
    ($(#[$doc:meta])* $name:ident, $what:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
        pub struct $name(pub u32);

        impl $name {
            /// The id as an index into the caller's own list.
            pub fn index(self) -> usize {
                self.0 as usize
            }
        }

        impl From<usize> for $name {
            fn from(i: usize) -> Self {
                $name(u32::try_from(i).expect(concat!($what, " index beyond u32")))
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{} {}", $what, self.0)
            }
        }
    };
}

id!(
    /// An image (one exposure) of a block.
    ImageId,
    "image"
);
id!(
    /// An object (ground, tie, check) point.
    PointId,
    "point"
);
id!(
    /// A camera (one interior orientation shared by its images).
    CameraId,
    "camera"
);
id!(
    /// A GNSS drift group (a block, a strip or an ambiguity segment).
    DriftId,
    "drift group"
);
id!(
    /// A GNSS latency group (the block, or one flight): one time offset δ between the
    /// exposure time and the GNSS time, seconds.
    LatencyId,
    "latency group"
);

/// The name of a parameter block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Key {
    /// Exterior orientation of an image (rotation and projection centre).
    Pose(ImageId),
    /// Coordinates of an object point.
    Point(PointId),
    /// Interior parameters of a camera (or a whole BAL camera).
    Camera(CameraId),
    /// GNSS antenna offset of a camera, in the camera frame.
    LeverArm(CameraId),
    /// Drift parameters of a GNSS drift group.
    Drift(DriftId),
    /// Time offset δ (s, one value) of a GNSS latency group.
    Latency(LatencyId),
    /// The boresight misalignment of a camera (three angles, radians): the rotation from the
    /// attitude the IMU gives to the camera's.
    Boresight(CameraId),
    /// Any other block: a kind name and a number, for observation kinds the list above does
    /// not know yet (no solver change is needed to add one).
    Custom(&'static str, u32),
}

/// The kind of a key, without its id (to choose which kinds are Schur-eliminated).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum KeyKind {
    /// [`Key::Pose`].
    Pose,
    /// [`Key::Point`].
    Point,
    /// [`Key::Camera`].
    Camera,
    /// [`Key::LeverArm`].
    LeverArm,
    /// [`Key::Drift`].
    Drift,
    /// [`Key::Latency`].
    Latency,
    /// [`Key::Boresight`].
    Boresight,
    /// [`Key::Custom`] with this kind name.
    Custom(&'static str),
}

impl Key {
    /// What kind of block this is.
    pub fn kind(&self) -> KeyKind {
        match self {
            Key::Pose(_) => KeyKind::Pose,
            Key::Point(_) => KeyKind::Point,
            Key::Camera(_) => KeyKind::Camera,
            Key::LeverArm(_) => KeyKind::LeverArm,
            Key::Drift(_) => KeyKind::Drift,
            Key::Latency(_) => KeyKind::Latency,
            Key::Boresight(_) => KeyKind::Boresight,
            Key::Custom(k, _) => KeyKind::Custom(k),
        }
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Key::Pose(i) => write!(f, "the orientation of {i}"),
            Key::Point(p) => write!(f, "{p}"),
            Key::Camera(c) => write!(f, "the interior orientation of {c}"),
            Key::LeverArm(c) => write!(f, "the lever arm of {c}"),
            Key::Drift(d) => write!(f, "the drift of {d}"),
            Key::Latency(l) => write!(f, "the latency of {l}"),
            Key::Boresight(c) => write!(f, "the boresight of {c}"),
            Key::Custom(k, n) => write!(f, "{k} {n}"),
        }
    }
}
