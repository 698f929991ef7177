import type { BufferGeometry, Intersection, Object3D, Raycaster } from 'three';
import type { Scene, SceneOptions } from './core.js';

/** The kd-tree of a BufferGeometry, kept as `geometry.boundsTree`. */
export declare class KdTree {
  constructor(geometry: BufferGeometry, options?: SceneOptions);
  readonly scene: Scene;
  readonly geometry: BufferGeometry;
  dispose(): void;
}
/** Loads the WebAssembly module ahead of time (optional: computeBoundsTree compiles it on first use). */
export declare function init(): Promise<void>;
/** A BufferGeometry method: builds `this.boundsTree`. */
export declare function computeBoundsTree(this: BufferGeometry, options?: SceneOptions): KdTree;
/** A BufferGeometry method: frees `this.boundsTree`. */
export declare function disposeBoundsTree(this: BufferGeometry): void;
/** Mesh.raycast over the kd-tree (three's own without one); honours raycaster.firstHitOnly. */
export declare function acceleratedRaycast(this: any, raycaster: Raycaster, intersects: Intersection[]): void;

export interface HierarchyRaycasterOptions {
  /** Cast objects whose `visible` is false too, as three's Raycaster does (default: skipped). */
  includeHidden?: boolean;
  /** Scene.build's options for the trees built per geometry. */
  build?: SceneOptions;
}
/**
 * Raycasts whole hierarchies in one call: every Mesh, InstancedMesh and BatchedMesh as an
 * instance of one top level over kd-trees kept per geometry; three's Intersection objects
 * (`instanceId`, `batchId` where three sets them), nearest first.
 */
export declare class HierarchyRaycaster {
  constructor(options?: HierarchyRaycasterOptions);
  includeHidden: boolean;
  intersectObject<T extends Object3D>(raycaster: Raycaster, object: Object3D, recursive?: boolean, intersects?: Intersection<T>[]): Intersection<T>[];
  intersectObjects<T extends Object3D>(raycaster: Raycaster, objects: Object3D[], recursive?: boolean, intersects?: Intersection<T>[]): Intersection<T>[];
  dispose(): void;
}
/** Raycaster.prototype.intersectObject over a shared HierarchyRaycaster. */
export declare function acceleratedIntersectObject<T extends Object3D>(this: Raycaster, object: Object3D, recursive?: boolean, intersects?: Intersection<T>[]): Intersection<T>[];
/** Raycaster.prototype.intersectObjects over the same. */
export declare function acceleratedIntersectObjects<T extends Object3D>(this: Raycaster, objects: Object3D[], recursive?: boolean, intersects?: Intersection<T>[]): Intersection<T>[];

declare module 'three' {
  interface BufferGeometry {
    boundsTree?: KdTree | null;
    computeBoundsTree(options?: SceneOptions): KdTree;
    disposeBoundsTree(): void;
  }
  interface Raycaster {
    firstHitOnly?: boolean;
  }
}
